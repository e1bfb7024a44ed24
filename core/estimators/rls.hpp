// Recursive least squares with optional exponential forgetting (vector-measurement form).
//
//   e = y − Φθ,  Γ = λI + ΦPΦᵀ (solved by Cholesky),  K = PΦᵀΓ⁻¹,  θ ← θ + Ke,
//   P ← (P − KΦP)/λ,  P ← (P + Pᵀ)/2.
// With λ = 1 and P0 = p0·I, θ after N updates is the ridge solution
//   θ = (I/p0 + ΣΦᵀΦ)⁻¹ (θ0/p0 + ΣΦᵀy).
// Wind-up guard: with λ < 1 and no excitation P would grow as λ^{-k}; the division by λ is skipped
// while trace(P) exceeds its initial value p0·p, so P stays bounded and θ finite.
#pragma once

#include "core/estimator.hpp"

namespace hysid {

class Rls final : public Estimator {
 public:
  Rls(const Vec& theta0, double p0, double forgetting);
  std::optional<Mat> covariance() const override { return p_; }
  const Mat* covariance_matrix() const override { return &p_; }
  std::string name() const override { return "rls"; }
  void Reset() override;

 private:
  void DoUpdate(ConstMatRef phi, ConstVecRef y) override;
  void ScalarUpdate(const double* phi, Eigen::Index stride, double y);

  Vec theta0_;
  Mat p_;
  double p0_;
  double lambda_;
  double max_trace_;
  Vec work_;  // P φ for the scalar path
  long rank_updates_ = 0;
};

}  // namespace hysid
