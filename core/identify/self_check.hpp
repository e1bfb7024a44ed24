// The recursive estimate checked against its own data (docs/method.md, "The recursive path checks
// itself"): an α̂ whose flow regression residuals contradict the data's noise, or a detector that found
// no jump in data that jump, is not ok.
//
// Per identified flow row r, over the samples taken for flow (γ = 0; a pair of consecutive finite
// samples in one chain), the residual e_k = Δξ_r(t_k) − Φ_r(t_k)α̂ (the flow regression of
// core/model/regression.hpp at the final α̂) against s_r = √2·σ̂_r, the sd of the noise of Δξ_r: σ̂ is
// IdentifierSettings::sigma when given and > 0, else the MAD of the row's second differences
// (EstimateNoiseSigma, which the rare jumps do not move); s_r is never below kResidualFloor × the RMS of
// the regressed left side (noise-free data: rounding and integrator error).
//   residuals  RMS(e) > kResidualRatio · s_r: the residual variance is more than 9× what the noise
//              explains (missed jumps in the flow regression, an estimate far off, a model that does
//              not fit).
//   no jump    the detector found no jump (IdentifyResult::jumps_detected = 0) and some |e_k| >
//              (√(2 ln K) + kOutlierMargin) · s_r over the K flow samples: Gaussian noise's largest of
//              K is ≈ √(2 ln K) sd, so the data jump there.
// Skipped (no verdict): given labels (the caller classified the samples), a hybrid automaton or given
// modes, fewer than kMinSamples flow samples, or no noise estimate (fewer than 4 samples).
#pragma once

#include <string>

#include "core/identify/identifier.hpp"

namespace hysid {

inline constexpr double kResidualRatio = 3.0;
inline constexpr double kOutlierMargin = 3.0;
inline constexpr double kResidualFloor = 1e-6;
inline constexpr long kMinSamples = 10;

// "" when the flow estimate is consistent with its data (or the check does not apply), else why not,
// naming the state row, the ratio and (no jump) the time of the largest residual.
std::string CheckFlowResiduals(const Model& model, const Mat& y, double dt,
                               const IdentifierSettings& settings, const IdentifyOptions& options,
                               const IdentifyResult& r);

}  // namespace hysid
