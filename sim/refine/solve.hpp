// What the output-error refinements (Refine, RefineChains) share. Internal to sim/refine.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <ceres/ceres.h>

#include "sim/refine/refine.hpp"

namespace hysid {

// The Ceres solve: Levenberg–Marquardt with RefineOptions' iteration budget and tolerances, one
// thread, Ceres' own logging silenced (the fit's status carries a failed evaluation).
ceres::Solver::Summary SolveLeastSquares(ceres::Problem& problem, const RefineOptions& options,
                                         ceres::LinearSolverType linear_solver);

// The integration accuracy per state component: residuals below it are numerical, not noise.
Vec NumericalFloor(const Mat& y, const SimOptions& sim);

// The fit's integration options (RefineOptions::noise_tolerance's rule) and residual weights 1/σ_i
// (σ given, else the MAD estimate) for the samples y.
void FitWeighting(const Mat& y, const RefineOptions& options, const Vec& mad_sigma, SensitivityOptions* sens,
                  Vec* weight);

// The samples before the first detected jump that follows the previous one by fewer than
// `min_interval` samples (jumps that close are not resolved reliably: the part before them is fit).
long FitLength(const std::vector<std::uint8_t>& gamma, long min_interval);

// Whether the model can be simulated at p: α, β and x0 finite, x0 in C or D. LeftDomain() is the
// trajectory that stands for one that cannot (status left-domain, with the reason).
bool Admissible(const Model& model, const HybridParameters& p);
SensitivityTrajectory LeftDomain();

// A failed fit: its status and the reason printed with it.
void Fail(RefineResult& r, RefineStatus status, std::string reason);

// The end of a fit: an ok fit's refined parameters become the estimate; a fit not ok keeps the
// recursive estimate and reports no covariance or standard errors.
void Conclude(RefineResult& r);

// The fit's residual checks from the normalised residuals z (n × K), their lag-1 sum `lag`, the
// residual σ, its MAD estimate from the data and the floor: sets normalized_rms and lag1, and fails
// with kResidualRms (RMS outside [rms_low, rms_high]; with σ estimated, σ over the MAD estimate above
// rms_high) or kResidualCorrelation (|lag1| > max_lag1 while the residuals are above the floor).
void JudgeResiduals(const Mat& z, double lag, const Vec& sigma_hat, const Vec& mad_sigma, const Vec& floor,
                    const RefineOptions& options, RefineResult& r);

}  // namespace hysid
