// Maximum-likelihood (output-error) refinement of a recursive estimate.
//
// Minimises Σ_k Σ_i ((y_ik − ξ_i(t_k; θ))/σ_i)² over θ = (unknown α, unknown β, ξ0), ξ read on the
// hybrid time domain of the detected jumps: sample k is compared with the model's segment
// j_k = Σ_{l≤k} γ_l, each segment's flow continued past the model's next jump and before its own
// start (SimulateSensitivitiesMatched), so no residual jumps as θ moves. (Plain residuals stall far
// from the optimum: samples that change side of a moving jump time dominate the cost.) Start: the
// recursive α̂, β̂ and ξ0 = y_0. Solver: Ceres, Levenberg–Marquardt with dense QR, Jacobian −S_k/σ_i
// from the hybrid forward sensitivities.
//
// The result is checked, and its status is not ok (the recursive estimate is then kept) when:
// the data are not finite, there are too few samples, the start does not simulate, Ceres does not
// converge, the fitted model is Zeno, its own jump count or jump times disagree with the detector's,
// the Fisher information is singular, the normalised residual RMS is outside [rms_low, rms_high]
// (σ estimated: the residual σ̂ above rms_high × the MAD estimate), or the residuals' lag-1
// autocorrelation exceeds max_lag1 (when they are above the integration accuracy). Never NaN.
// A jump-count mismatch or a failed start is first retried on a span that ends before the first
// disagreement between the model's jumps and the detected ones (RefineOptions::max_span_retries).
// A fit that still fails (other than for the data or their length) is tried once more from a
// repaired start (sim/refine/start.hpp: detections the local flows do not need dropped, the others
// moved to where the flows meet, missed jumps added, β and ξ0 re-estimated); the status is then
// that fit's when it is ok, else the first fit's.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/identify/identifier.hpp"
#include "sim/refine/start.hpp"
#include "sim/sensitivity/crlb.hpp"

namespace hysid {

enum class RefineStatus {
  kOk,
  kNonFiniteData,        // y has a NaN or an infinity
  kTooFewSamples,        // fewer samples than unknowns + 1 per component
  kStartFailed,          // the start does not simulate on the detected segments
  kNotConverged,         // Ceres stopped without convergence (iteration budget, failed steps)
  kZeno,                 // the fitted model is Zeno within the horizon, or its jumps accumulate
                         // faster than the samples (more jumps than detected, the last ones less
                         // than a sample apart)
  kJumpCountMismatch,    // the fitted model's jump count or jump times disagree with the detector's
  kSingularFisher,       // some direction of θ is not identifiable at the fit
  kResidualRms,          // normalised residual RMS far from 1: the fit (or σ) is wrong
  kResidualCorrelation,  // residuals not white: the model or the segmentation is wrong
};
const char* ToString(RefineStatus status);

struct RefineOptions {
  // Integration of the fits: budgets, the Zeno rule, and the loosest tolerances (rtol = atol) used.
  // The fits integrate at rtol = atol = noise_tolerance · min_i σ_i / max(1, max_k |y_ik|) (σ given or
  // the MAD estimate), clamped to [polish_tolerance, sensitivity.sim.rtol]: an integration error far
  // below the noise changes the estimate by a negligible fraction of its standard error.
  SensitivityOptions sensitivity = [] {
    SensitivityOptions s;
    s.sim.rtol = 1e-6;
    s.sim.atol = 1e-6;
    return s;
  }();
  double noise_tolerance = 1e-4;
  // Residuals at the integration accuracy after the fit (noise-free data): a second fit from there at
  // rtol = atol = polish_tolerance (no polish when it is not below the tolerances above).
  double polish_tolerance = 1e-12;
  int max_iterations = 50;
  double function_tolerance = 1e-9;   // Ceres: relative cost decrease
  double parameter_tolerance = 1e-9;  // Ceres: relative step
  Vec sigma;                          // per component (n entries ≥ 0) when known; empty: estimated
  double rms_low = 0.8;               // σ given: normalised residual RMS in [rms_low, rms_high]
  double rms_high = 1.25;  // σ estimated: residual σ̂ ≤ rms_high × MAD σ̂ (core/model/noise_shape)
  double max_lag1 = 0.2;   // |lag-1 autocorrelation| of the normalised residuals
  double jump_time_tolerance = 3.0;
  // Detected jumps closer than this many samples are not resolved reliably (a bouncing ball nearing
  // its Zeno time): the samples before the first such jump are fit (RefineResult::samples_used).
  // 0: always all samples.
  long min_jump_interval = 50;
  // When the (start or fitted) model's jumps disagree with the detected ones in the span (jump-count
  // mismatch or start failure), the span is cut to end ceil(jump_time_tolerance) + 2 samples before
  // the first disagreement and fit again, at most this many times (0: never).
  int max_span_retries = 3;
  // A failed fit is tried again from a repaired start (see above); false: never.
  bool repair_start = true;
  StartRepairOptions start_repair;
  // Field-naming message, e.g. "RefineOptions::rms_low = 2: must be in (0, rms_high)".
  bool IsValid(std::string* error) const;
};

struct RefineResult {
  RefineStatus status = RefineStatus::kOk;
  std::string reason;  // why the status is not ok ("" when ok)
  bool ok() const { return status == RefineStatus::kOk; }
  std::vector<std::string> names;  // θ's entries
  Unknowns unknowns;
  HybridParameters start;     // the recursive estimate, ξ0 = y_0
  HybridParameters refined;   // Ceres' final point (equal to start when it did not run)
  HybridParameters estimate;  // refined when ok, else start
  // At the refined point when ok (else empty): F(θ̂)⁻¹ with σ (given, or from the residuals), and
  // its square-rooted diagonal.
  Mat covariance;
  Vec standard_errors;
  Vec sigma;  // σ used for the covariance (n)
  bool sigma_estimated = false;
  double normalized_rms = 0.0;  // σ given: RMS of r/σ; estimated: max_i σ̂_i / MAD σ̂_i
  double lag1 = 0.0;            // lag-1 autocorrelation of the normalised residuals
  int iterations = 0;
  double initial_cost = 0.0, final_cost = 0.0;  // ½ Σ (r/σ_w)² with the weighting σ
  long samples_used = 0;     // the fitted prefix of the samples (see RefineOptions::min_jump_interval)
  std::string span_reason;   // why samples_used < K ("" when all samples are fit)
  int detected_jumps = 0;    // in the fitted prefix (of the repaired detections when start_repair is set)
  std::string start_repair;  // what the repaired start changed, when the result comes from it ("" else)
  int model_jumps = -1;      // of the fitted model over the horizon (−1: not simulated)
  // RefineChains: the initial state fitted for each chain (start: its first sample; empty for a
  // chain left out), how many chains were fit and how many left out (too short, or their first
  // sample outside C ∪ D), and per chain the samples fit (0: left out) and why the others were left
  // out ("" when all were fit; span_reason joins them, "chain c: …").
  std::vector<Vec> chain_x0;
  long chains_used = 0, chains_skipped = 0;
  std::vector<long> chain_samples_used;
  std::vector<std::string> chain_span_reason;
};

// y: n × K samples at t_k = k·dt; alpha0, beta0: full vectors (the recursive estimate); gamma: one
// entry per sample (1 = a jump detected in (t_{k−1}, t_k]; gamma[0] is ignored). Throws
// std::invalid_argument for inputs of the wrong size or invalid options; numerical outcomes are
// statuses.
RefineResult Refine(const Model& model, const Mat& y, double dt, const Vec& alpha0, const Vec& beta0,
                    const std::vector<std::uint8_t>& gamma, const RefineOptions& options = {});

// One chain of samples for RefineChains: consecutive samples of one run, no gap between them.
struct RefineChain {
  std::vector<double> t;            // sample times, increasing (any origin)
  Mat y;                            // n × K, finite
  std::vector<std::uint8_t> gamma;  // 1 = a jump detected in (t_{k−1}, t_k]; gamma[0] is ignored
};

// The chains of samples (t, y: n × K, gamma as RefineChain's) cut where chain_start is 1 (sample 0
// always starts one). Throws std::invalid_argument for sizes that disagree.
std::vector<RefineChain> SplitChains(const std::vector<double>& t, const Mat& y,
                                     const std::vector<std::uint8_t>& chain_start,
                                     const std::vector<std::uint8_t>& gamma);

// Several chains of one system (several runs, or one run cut at gaps and missing samples), samples
// at their own times. θ = (unknown α, unknown β) shared, plus one initial state per chain (its own
// Ceres parameter block, start: the chain's first sample). Each chain is simulated on its own times
// from its own start; nothing is integrated across a gap. Per chain the span rule of Refine
// (min_jump_interval) applies; chains with fewer than 2n + 2 samples are left out. Checks as Refine,
// per chain (start, Zeno, jump count and times) and pooled (σ, RMS, lag-1 within chains). Recoveries
// as Refine's: a jump-count mismatch or start failure of one chain cuts that chain's span before its
// first disagreement and fits again (max_span_retries per chain; chain_span_reason says why); a fit
// still not ok, or ok only on cut spans, is tried from a repaired start (each chain's labels and
// initial state from RepairStart on that chain, α̂ kept, β from all chains' jump regressions pooled),
// adopted when it is ok (start_repair). names, covariance and standard_errors cover the shared
// unknowns only (their block of the joint F⁻¹), `unknowns` has x0 = false; estimate.x0 is the first
// fitted chain's, chain_x0 all.
RefineResult RefineChains(const Model& model, const std::vector<RefineChain>& chains, const Vec& alpha0,
                          const Vec& beta0, const RefineOptions& options = {});

// The same from an identification run: its α̂, β̂ and γ.
RefineResult RefineIdentification(const Model& model, const Mat& y, double dt,
                                  const IdentifyResult& recursive, const RefineOptions& options = {});

}  // namespace hysid
