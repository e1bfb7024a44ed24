// What a figure of a fit draws beside the data (docs/outputs.md, identify's trace and `fitted_events`):
// the fitted model run on its own over every whole chain of the record, per sample, with the band of
// its states from the refinement's covariance, the recursive estimate's model run likewise, and the
// fitted model's own events with their standard errors.
//
// The fitted run: the reported estimate (RefineResult::reported: refined α, β, γ and each chain's
// fitted ξ0 and mode) simulated on the chain's sample times from its first sample, in plain mode: each
// sample on the segment the model itself is in then (its own events, not the detected ones), so past
// a span the fit cut it is the model's prediction. Band: sd_ik = √(S_k,i C S_k,iᵀ), S_k = ∂ξ(t_k)/∂θ and
// C the refinement's covariance of θ with the chain's own ξ0 (RefineResult::chain_covariance), on every
// fitted chain. A jump's standard error: √(gᵀCg), g = ∂t_j/∂θ (saltation,
// sim/sensitivity/sensitivity.hpp), likewise.
// The recursive run: the recursive estimate (RefineResult::start's α, β, γ) from each chain's first
// sample (its measured states; a hidden state's start as the identifier had it) and the recursive
// pass's mode there. The residuals a figure shows are y − `matched`.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/identify/identifier.hpp"
#include "sim/refine/refine.hpp"

namespace hysid {

// One jump of the fitted model, on the data's clock.
struct FittedJump {
  double time = 0.0;
  double se = 0.0;      // NaN in a chain not fitted or without a covariance
  int chain = 0;        // 0-based, SplitChains' order
  int map = 0;          // the jump map applied (0 for the paper's class)
  int mode_after = 0;   // the mode after it
  bool in_fit = false;  // inside its chain's fitted span (RefineResult::chain_samples_used)
};

struct FittedOutputs {
  // n × K, per sample of the data (the columns of y): NaN in a chain not fitted, after a run that
  // stopped (Zeno, left the domain), and everywhere when the refinement reported no fit.
  Mat x, sd;
  // n × K: the fitted run read on the detected segments (the recursive pass's gamma), as the
  // refinement compares it with the data: each segment's flow continued past its jump, so a sample
  // between a detected jump and the model's own is read on the data's side (SimulateSensitivitiesMatched);
  // x where that run does not reach every detected segment (the detections are not the model's).
  Mat matched;
  Mat recursive;  // n × K: the recursive estimate's run (NaN after it stops or where it cannot start)
  std::vector<int> mode;             // the fitted run's mode per sample (−1: none); empty for one mode
  std::vector<std::uint8_t> in_fit;  // 1: the sample is inside its chain's fitted span
  std::vector<FittedJump> jumps;     // every jump of the fitted runs, chains in order
  std::string reason;                // where and why x is NaN ("" when nowhere)
  std::string recursive_reason;      // the same for `recursive`
};

// (t, y: n × K, chain_start, u: m × K or empty) are the samples the refinement was given; `refined`
// its result (RefineResult::start alone, with no fit, for an identification without refinement).
// Tolerances: rtol = atol = 1e-9. Throws std::invalid_argument for sizes that disagree.
FittedOutputs RunFittedModel(const Model& model, const std::vector<double>& t, const Mat& y,
                             const std::vector<std::uint8_t>& chain_start, const Mat& u,
                             const IdentifyResult& recursive, const RefineResult& refined);

}  // namespace hysid
