// The recursive pass of a hybrid automaton (docs/architecture.md "Systems as measured and hybrid
// automata", Identification): its events found, each assigned to a jump map, the mode of every sample
// and the initial mode inferred, then the paper's pass with each sample's mode (φ_q) and each jump's
// map (ψ_m).
//
//   Jumps      the jump detector of the one-mode pass (as for the paper's class; models with a map
//              that is not an identity), or IdentifyOptions::labels when given. With several modes:
//              first the pairs flagged by the pass of every mode (all samples in that mode) and
//              isolated (a run of flags is a pass's α̂ catching up with a flow it was not given);
//              then, up to 3 rounds until they agree, the pass with the modes and maps the events
//              give (its isolated flags, none at a switch's pair), and the events again.
//   Switches   kinks (DetectKinks; models with an identity map): mode switches leave ξ continuous
//              and change its slope.
//   Assignment walking the events in time order from the initial mode q: the maps of the event's
//              kind (identity for a switch, ψ for a jump) armed in q; of several, the one whose guard
//              is nearest zero, |h|/‖∇ₓh‖ least over the flow step from the pre-event sample (γ the
//              model's: its start). Then q = the map's `to`.
//   Initial q  given (IdentifyOptions::initial_mode), else every mode is tried and the one whose flow
//              regression (least squares over all flow pairs, with each sample's mode) leaves the
//              least residual sum of squares is kept; when two modes' sums agree to a relative 1e-6
//              (their φ have one form, as with a library of candidate terms in every mode: either
//              labelling fits alike), the one under which fewer switches cross their guards against
//              the guards' directions (h from the sample a kink window before the switch's pre-switch
//              sample to that sample, within its flow segment; a guard that reads an unmeasured state
//              does not count: those rows are a reconstruction).
#pragma once

#include <cstdint>
#include <vector>

#include "core/identify/identifier.hpp"

namespace hysid {

// One kink: the first sample after it, its located instant and its statistic.
struct Kink {
  long sample = 0;
  double time = 0.0;
  double statistic = 0.0;
};

// Kinks of y (n × K at times t) within the segments that `breaks` delimit (breaks[k] = 1: no flow
// between samples k − 1 and k: a jump, a chain start; a column with a non-finite entry is a break on
// both sides). Per candidate k (a switch in (t_{k−1}, t_k]) and component j, degree-2 fits to the
// window before and the window after give the slopes at (t_{k−1} + t_k)/2; the statistic is the
// largest over j of |difference| over its standard deviation (σ_j: `sigma`). A peak (above the
// threshold, the largest within ±window) is then placed at the split of its window whose two fits
// leave the least squared residual (σ_j-weighted), within ±2 samples, and its instant where the two
// fits meet inside (t_{k−1}, t_k] (the middle when they do not).
std::vector<Kink> DetectKinks(const Mat& y, const std::vector<double>& t, const std::vector<std::uint8_t>& breaks,
                              const Vec& sigma, const KinkSettings& settings);

// The events (jumps: samples k with jumps[k] = 1; switches: kinks) in time order, assigned from
// mode `initial_mode` (the rule above); α for the flow step; inputs m × K or empty. Writes the mode
// of every sample and the map of every jump sample (0 elsewhere).
std::vector<AutomatonEvent> AssignEvents(const Model& model, const Mat& y, const std::vector<double>& t,
                                         const Mat& inputs, const Vec& alpha, int initial_mode,
                                         const std::vector<std::uint8_t>& jumps, const std::vector<Kink>& kinks,
                                         std::vector<int>* modes, std::vector<int>* maps);

// The residual sum of squares of the least-squares flow regression over every pair (k − 1, k) not
// split by `breaks`, φ at each sample's mode. NaN when no pair is usable.
double ModeResidual(const Model& model, const Mat& y, const std::vector<double>& t, const Mat& inputs,
                    const std::vector<std::uint8_t>& breaks, const std::vector<int>& modes);

// Identify() for a hybrid automaton with IdentifyOptions::assign_events (it calls this).
IdentifyResult IdentifyAutomaton(const Model& model, const Mat& y, double dt, const IdentifierSettings& settings,
                                 const IdentifyOptions& options);

}  // namespace hysid
