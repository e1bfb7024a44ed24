// What the lockstep driver (IdentifyLockstep, core/identify/lockstep.cpp) asks of an identifier,
// beyond the public Identifier (not installed): Identify in parts, a flow run driven from outside,
// and the twins' questions.
#pragma once

#include "core/identify/flow_run_unit.hpp"
#include "core/identify/identifier.hpp"

namespace hysid::detail {

// Identify in parts, for IdentifyLockstep, which feeds the pass of several identifiers itself.
// PassInBlocks: whether Identify's pass feeds the samples in blocks (no hybrid automaton to assign, no
// times, chains, inputs, modes, labels or trace, all samples finite; and IdentifierSettings::second_pass
// off). StartIdentify: Identify's checks (throwing as it does) and its identifier, *r sized for the
// pass. FinishIdentify: after the pass (`completed` false: stopped), what Identify does after it
// (final estimates, statuses, hulls, the detector's bound, the safe start).
bool PassInBlocks(const Model& model, const Mat& y, const IdentifyOptions& options);
Identifier StartIdentify(const Model& model, const Mat& y, double dt, const IdentifierSettings& settings,
                         const IdentifyOptions& options, IdentifyResult* r);
void FinishIdentify(const Model& model, const Mat& y, double dt, const IdentifierSettings& settings,
                    const IdentifyOptions& options, Identifier& id, bool completed, IdentifyResult* r);

// A flow run driven from outside, so that identifiers on the same samples with the same flow rows
// run side by side. BeginFlowRun: whether Feed would now take a flow run with |α| = A (two states, RLS
// for two unknowns and the paper detector called directly, warm-up over, no sets, first pass, a sample
// fed before); its state then in *unit. EndFlowRun: the run stepped `unit` over samples 0 … k − 1 of a
// block (xs: its first sample, n × count contiguous; phi, y: its flow rows as in Feed; decisions: the
// block's, written) and stopped at k: its state written back, sample k's decision `pending` (k < count;
// null when none, as before a non-finite row) applied as the per-sample path applies it, and the
// block's samples after that fed by the identifier's own path. The same bits as Feed on the block.
// EndFlowRun returns where it stopped (StopAtJumps), else count.
template <int A>
bool BeginFlowRun(const Identifier& id, FlowRunUnit<A>* unit);
template <int A>
Eigen::Index EndFlowRun(Identifier& id, const FlowRunUnit<A>& unit, const double* xs, Eigen::Index k,
                        Eigen::Index count, const double* phi, const double* y, const Decision* pending,
                        Decision* decisions);

// One identifier for several units that differ only in the detector's threshold, until their
// decisions differ (the twins; two states, one identified row with two unknowns, RLS for α, the paper
// or the residual detector called directly, no sets, first pass).
// Leads: whether `twin` (built for the same model, δt and samples) may follow `leader`: its settings
// equal except the detector's r or false_alarm, and its threshold at least leader's wherever the two
// would decide with the same learned state, so that wherever leader decides flow, so does twin. Only
// leader's jumps need asking then.
bool Leads(Identifier& leader, Identifier& twin);
// StopAtJumps(id, true): EndFlowRun, FeedRest and ApplyAndFeed stop before they apply a jump (the
// sample classified, not counted, not applied) and return its index; its decision is Stopped(id).
// Feed and Step throw std::logic_error when they would stop.
void StopAtJumps(Identifier& id, bool on);
const Decision& Stopped(const Identifier& id);
// Whether follower's detector, with `leader`'s learned state, flags the sample `cur` at which leader
// stopped (Leads(leader, follower) held).
bool Flags(Identifier& follower, const Identifier& leader, const double* cur);
// `follower` becomes a copy of `leader`'s state, with its own settings.
void AdoptState(Identifier& follower, const Identifier& leader);
// From sample k of a block (xs: its samples, 2 × count; phi, y: its flow rows as in Feed; its
// decisions written): FeedRest feeds samples k … count − 1; ApplyAndFeed first applies decision d to
// sample k. Both return where they stopped, else count.
Eigen::Index FeedRest(Identifier& id, const double* xs, Eigen::Index k, Eigen::Index count, const double* phi,
                      const double* y, Decision* decisions);
Eigen::Index ApplyAndFeed(Identifier& id, const double* xs, Eigen::Index k, Eigen::Index count,
                          const double* phi, const double* y, const Decision& d, Decision* decisions);

}  // namespace hysid::detail
