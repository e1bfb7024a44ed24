// Several identifications of the same samples that differ only in their settings (a sweep trial's
// units: the paper detector at several r, the residual detector …), their passes fed together.
//
// The samples go to the identifiers in blocks of kLockstepBlock. In each block, the identifiers
// that can take a flow run there (detail::BeginFlowRun: two states, RLS for two unknowns and the
// paper detector, warm-up over, no sets) run in lockstep, up to kMaxLockstep at a time: per sample,
// each classifies and updates α̂ in turn (detail::FlowRunUnit::Step), so their dependency chains,
// each one RLS update and one classification long, overlap in the core instead of running one after
// the other. A unit whose run stops (a jump, a failed update) leaves the lockstep: its decision is
// applied and the rest of the block fed by its own path (detail::EndFlowRun); a non-finite row
// ends the run of all. The others go on together, and every unit joins again at the next block.
// The other identifiers are fed each block alone (Identifier::Feed with the shared flow rows).
// Without statistics, units that differ only in the detector's threshold are twins: one identifier
// (the smallest threshold's) is fed for all of them until their decisions differ, and a unit that
// leaves takes a copy of its state (detail::Leads, StopAtJumps, Flags, AdoptState in
// core/identify/lockstep_units.hpp;
// docs/architecture.md, "Twins").
// Each unit's arithmetic is its own pass's, so every result is bit for bit Identify's.
#pragma once

#include <vector>

#include "core/identify/identifier.hpp"

namespace hysid {

inline constexpr int kMaxLockstep = 8;                // identifiers stepped side by side at most
inline constexpr Eigen::Index kLockstepBlock = 256;  // samples per block

// Unit-samples taken in lockstep (samples × units that took them there), decided by a twin's
// identifier (a follower's samples), of all.
struct LockstepCounts {
  long lockstep = 0;
  long shared = 0;
  long total = 0;
};

// Identify(model, y, dt, settings[i], options) for each i, in that order, the same bits. Fed
// together when there are several, their pass feeds blocks (detail::PassInBlocks, no second pass), and the
// model has two states and one identified flow row with two unknowns; otherwise one Identify after
// the other. The flow rows are options.flow_rows when given, else built once for all. `counts`,
// unless null, receives how many unit-samples went through the lockstep. Throws as Identify does.
std::vector<IdentifyResult> IdentifyLockstep(const Model& model, const Mat& y, double dt,
                                             const std::vector<IdentifierSettings>& settings,
                                             const IdentifyOptions& options = {}, LockstepCounts* counts = nullptr);

}  // namespace hysid
