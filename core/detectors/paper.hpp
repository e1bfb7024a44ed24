// The paper's jump detector (§3, eq. 3): γ(t) = 1 when the Euler derivative
//   D_δt ξ(t) = ‖ξ(t) − ξ(t−δt)‖ / δt
// exceeds the estimated smoothness bound
//   τ̂(t) = (r/2) · L̂ · (‖ξ(t)‖ + ‖ξ(t−δt)‖),   L̂ = sup_{ξ∈Ĉ} ‖∂f̂_r/∂ξ‖,
// where f̂_r are the identified rows of the estimated flow φ(ξ)α̂ (§5: L̂ = ‖α̂‖ for impact-msd).
// τ̂ = τ̂0 until the α estimator has seen as many flow samples as it has unknowns.
//
// Bound modes (DetectorSettings::bound):
//   paper        as above;
//   homogeneous  for affine flows (f(0) ≠ 0, e.g. gravity), where ‖f(ξ)‖ ≤ L‖ξ‖ fails near ξ = 0:
//                ξ̄ = [ξ; 1], L̂ = ‖[∂f̂_r/∂ξ, f̂_r(0)]‖, norms ‖ξ̄‖ — then ‖f(ξ)‖ ≤ L̂‖ξ̄‖ holds.
//   auto         paper when φ_r(0) = 0 (f̂_r(0) = 0 for every α̂), homogeneous otherwise.
// The sup over Ĉ: constant Jacobians (ModelSpec::flow_jacobian_constant) need one evaluation; others
// are evaluated at the vertices of Ĉ (the hull of Λ) and at ξ(t−δt), ξ(t) — the exact sup for a
// norm convex in ξ over a polytope, an approximation otherwise.
#pragma once

#include <cmath>

#include "core/detector.hpp"

namespace hysid {

enum class BoundMode { kPaper, kHomogeneous };

// Resolves "auto" / "paper" / "homogeneous" for a model; throws for another name.
BoundMode ResolveBoundMode(const std::string& bound, const Model& model);

// L̂ for the full parameter vector `alpha` at the states in the columns of `points` (at least one
// column; only one is used when the Jacobian is constant).
double SupJacobianNorm(const Model& model, ConstVecRef alpha, BoundMode mode,
                       const Eigen::Ref<const Mat>& points);

// λmax(AAᵀ) = ‖A‖₂².
double SpectralNormSquared(const Eigen::Ref<const Mat>& a);

// ‖ξ‖ (paper) or ‖[ξ; 1]‖ (homogeneous).
inline double BoundNorm(const double* x, Eigen::Index n, BoundMode mode) {
  double s = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) s += x[i] * x[i];
  return std::sqrt(mode == BoundMode::kHomogeneous ? s + 1.0 : s);
}
inline double BoundNorm(ConstVecRef x, BoundMode mode) { return BoundNorm(x.data(), x.size(), mode); }

class PaperDetector final : public JumpDetector {
 public:
  PaperDetector(const DetectorSettings& settings, const Model& model);
  Decision Classify(const SampleContext& context) override;
  std::string name() const override { return "paper"; }
  void Reset() override;
  BoundMode mode() const { return mode_; }

 private:
  double r_;
  double tau0_;
  BoundMode mode_;
  bool constant_jacobian_;
  int unknowns_;
  // Constant Jacobians are linear in α: vec(J̄_r(α)) = G α, G precomputed (rows × |α|) from unit α.
  Mat g_;
  int reduced_rows_ = 0;
  Vec jvec_;
  Mat gram_;  // GᵀG (|α| × |α|): ‖J̄_r(α)‖² = αᵀGᵀGα for one identified row
  double LinearNormSquared(ConstVecRef alpha);
  // Cache of the part of L̂ that depends only on α̂ and Ĉ.
  long cached_version_ = -1;
  long cached_hull_version_ = -1;
  double cached_l2_ = 0.0;
  double cached_l_ = 0.0;  // √cached_l2_ (constant Jacobians)
  // ξ(t) of the previous call and its BoundNorm: the next call's ξ(t−δt) when pairs are consecutive.
  Vec last_x_;
  double last_norm_ = 0.0;
  Mat points_;
};

}  // namespace hysid
