// Detections mended from the fitted model: the labels placed at the fitted model's own jumps, fit
// again while that fits the data better. Internal to sim/refine.
#pragma once

#include <string>
#include <vector>

#include "sim/refine/fit.hpp"

namespace hysid {

// Fits that place the labels at the model's own jumps: at most this many per call.
constexpr int kMendRounds = 4;

// After the fit r from s whose jumps disagree with chain `failure.chain`'s labels (r not ok, with the
// failure's model jumps): that chain's labels over its fitted span mended from its fitted model
// (MendFromModel: a model jump within `reach` samples of a label keeps it, one without is added, a
// label no model jump takes is dropped), the chains fit again from r's point; while that fit's jumps
// still disagree with its chain's labels, s's labels are mended in the same way from its own model's
// jumps and fit again, at most kMendRounds fits in all. true (r and s replaced, r.mended extended) when a
// fit is ok and fits as many samples as r.
bool MendFromFit(const Model& model, const std::vector<RefineChain>& chains, const RefineOptions& options,
                 ChainFailure failure, long reach, FitStart& s, RefineResult& r);

// After the ok fit r from s: every fitted chain's labels over all its samples mended from its fitted
// model's own jumps, and the chains fit again from r's point, while that changes a label, at most
// kMendRounds times. `place`: each label placed at the model's jump (the sample whose interval holds
// it; labels a detector placed a few samples off then stop biasing the fit); else only a model jump
// with no label within max(⌈jump_time_tolerance⌉ + 1, min_jump_interval) samples is added (a fit ok only on spans the retries
// cut short carried to the whole chain when the jump it missed is in the data). A fit replaces r when
// it is ok and fits more samples, or as many at a lower cost (the same data: a higher likelihood).
// true when r changed (r.mended then ends with what changed against the detector's labels).
bool SettleAtModelJumps(const Model& model, const std::vector<RefineChain>& chains,
                        const RefineOptions& options, bool place, FitStart& s, RefineResult& r);

}  // namespace hysid
