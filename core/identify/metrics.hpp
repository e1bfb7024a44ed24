// Metrics of an identification run against the simulator's ground truth.
#pragma once

#include <cstdint>
#include <vector>

#include "core/detectors/detector.hpp"
#include "core/model/model.hpp"

namespace hysid {

// Per-sample confusion of γ against the truth; sample k ≥ 1 is a true jump when a jump happened in
// (t_{k−1}, t_k], i.e. j_k ≠ j_{k−1}. Sample 0 is not scored.
struct Confusion {
  long tp = 0, fp = 0, fn = 0, tn = 0;
  long total() const { return tp + fp + fn + tn; }
  double misclassification() const;  // (fp + fn) / total (0 when total = 0)
  double precision() const;          // tp / (tp + fp); 1 when nothing was flagged
  double recall() const;             // tp / (tp + fn); 1 when there was nothing to find
};
// Throws std::invalid_argument when the sizes differ.
Confusion CompareJumps(const std::vector<int>& j_true, const std::vector<std::uint8_t>& gamma);

struct ParameterErrors {
  double e_alpha = 0.0, e_beta = 0.0;      // ‖α − α̂‖, ‖β − β̂‖ (full vectors)
  double rel_alpha = 0.0, rel_beta = 0.0;  // over the unknown entries: ‖α_u − α̂_u‖/‖α_u‖
};
ParameterErrors CompareParameters(const Model& truth, const Vec& alpha_hat, const Vec& beta_hat);

// The smoothness bound τ(t) of eq. (2)–(3) with the true flow: (1/2)·L·(‖ξ(t)‖ + ‖ξ(t−δt)‖) with the
// bound mode of `settings` (paper / homogeneous) and L from the true α over the true states.
// One value per sample (τ[0] = 0). e_τ(t) = |τ̂(t) − r·τ(t)|.
std::vector<double> TrueSmoothnessBound(const Model& model, const Mat& x_true,
                                        const DetectorSettings& settings);

}  // namespace hysid
