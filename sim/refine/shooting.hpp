// Multiple shooting for the output-error refinement (sim/refine/refine.hpp): each chain split into
// segments of a few detected jumps, each segment with its own free initial state, consecutive
// segments of one chain linked by continuity residuals (FitStart::continues). A route to the
// single-shooting fit, not an estimator of its own. Internal to sim/refine.
#pragma once

#include <cstddef>
#include <vector>

#include "sim/refine/fit.hpp"

namespace hysid {

// The segments of the chains and their start.
struct ShootingSegments {
  std::vector<RefineChain> chains;  // the segments, chain by chain, in order
  FitStart start;                   // θ from the given start; each segment's ξ0 its first sample
  std::vector<std::size_t> chain;   // per segment: the chain it belongs to
};

// The segments of the chains from s fit by multiple shooting, their labels mended from their own
// fitted models (every segment at once, until none changes, at most kShootingRounds fits), and the
// single-shooting start of the chains from that fit (*joined): its θ, each chain's ξ0 its first
// segment's, the segments' labels joined. `jumps` detected jumps per segment. false when no chain is
// cut into segments or their fit ends without a point (*shot then says why).
bool ShootSegments(const Model& model, const std::vector<RefineChain>& chains, const FitStart& s,
                   const RefineOptions& options, RefineResult* shot, FitStart* joined);
constexpr int kShootingRounds = 4;
// At most this many segments (else the route is not tried: its reason says so).
constexpr std::size_t kMaxShootingSegments = 200;

}  // namespace hysid
