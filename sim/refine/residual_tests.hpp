// Residual tests of an output-error fit at a stated size (the probability that residuals of a fit
// at the noise are refused), calibrated to the number of residuals: the level Σ(r/σ)² against the
// χ²_{N−p} law (σ given) and the lag-1 autocorrelation ρ̂₁ through √N ρ̂₁ ≈ N(0, 1).
#pragma once

#include <vector>

#include "core/model/model.hpp"

namespace hysid {

// For N residuals of a fit of p unknowns at the size alpha: the two-sided bounds of Σ(r/σ)² (each
// tail alpha/4) and the bound of |√N ρ̂₁| (two-sided, alpha/2).
struct ResidualLimits {
  double level_low = 0.0, level_high = 0.0;
  double z = 0.0;
};
ResidualLimits ResidualLimitsFor(long N, double parameters, double alpha);

// The residual tests of an output-error fit, each at the size `alpha` / 2:
//  level (σ given): Σ (r/σ)² against χ²_{N−p} (two-sided);
//  whiteness: per measured row, z = √N ρ̂₁ with ρ̂₁ the lag-1 autocorrelation within chains, |z| against
//  the normal quantile of size alpha / (2 · rows) (Bonferroni).
// `residuals` per chain: rows × K (raw residuals; a non-finite entry is a sample left out of the tests); `sigma`
// per row (given or estimated); `given`: σ given.
struct ResidualTestResult {
  double level_statistic = 0.0;  // Σ (r/σ)² / (N − p): near 1 for a fit at the noise
  bool level_ok = true;
  double worst_z = 0.0;  // the largest |√N ρ̂₁| over rows
  double lag1 = 0.0;     // ρ̂₁ of that row
  bool white = true;
};
ResidualTestResult ResidualTests(const std::vector<Mat>& residuals, const Vec& sigma, bool given, double parameters,
                                 double alpha);

// The level with σ estimated: the largest σ̂_i / MAD σ̂_i (core/model/noise_shape: the data's own
// noise from their second differences) over the measured rows whose MAD estimate is above their
// numerical floor; 0 when none is. Above RefineOptions::rms_high the residuals are not at the noise.
double SigmaOverMad(const Vec& sigma_hat, const Vec& mad_sigma, const Vec& floor);

// The meat of the sandwich covariance when the residuals are not white: the Newey–West (Bartlett)
// estimate Σ_k g_k g_kᵀ + Σ_{l=1}^{L} (1 − l/(L+1)) Σ_k (g_k g_{k−l}ᵀ + g_{k−l} g_kᵀ) of the scores'
// autocovariance, within chains, L = ⌊4 (N/100)^{2/9}⌋ for N scores in all. `scores` per chain: one
// score g_k ∈ ℝ^P per sample.
Mat NeweyWestMeat(const std::vector<std::vector<Vec>>& scores, Eigen::Index P);

}  // namespace hysid
