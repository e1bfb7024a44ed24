// Recursive least squares with optional exponential forgetting (vector-measurement form).
//
//   e = y − Φθ,  Γ = λI + ΦPΦᵀ (solved by Cholesky),  K = PΦᵀΓ⁻¹,  θ ← θ + Ke,
//   P ← (P − KΦP)/λ,  P ← (P + Pᵀ)/2.
// With λ = 1 and P0 = p0·I, θ after N updates is the ridge solution
//   θ = (I/p0 + ΣΦᵀΦ)⁻¹ (θ0/p0 + ΣΦᵀy).
// Wind-up guard: with λ < 1 and no excitation P would grow as λ^{-k}; the division by λ is skipped
// while trace(P) exceeds its initial value p0·p, so P stays bounded and θ finite.
#pragma once

#include <cmath>

#include "core/estimators/estimator.hpp"

namespace hysid {

namespace detail {

// One scalar row, the common case (one identified state component). P = the parameter count when
// known at compile time (the loops unroll), or 0 for any p. `stride` is the distance between φ's
// entries: a 1×p row of a column-major matrix binds to ConstMatRef without a copy and then has
// outerStride() = the parent's row count. Returns false (nothing changed) when φᵀPφ + λ is not a
// positive finite number.
template <int P>
inline bool ScalarRlsUpdate(Eigen::Index p_dynamic, double* pp, double* theta, double* g, const double* phi,
                            Eigen::Index stride, double y, double lambda, double max_trace) {
  const Eigen::Index p = P > 0 ? P : p_dynamic;
  double denom = lambda;
  double pred = 0.0;
  for (Eigen::Index i = 0; i < p; ++i) {
    double s = 0.0;
    // P symmetric: (Pφ)_i
    for (Eigen::Index k = 0; k < p; ++k) s += pp[k * p + i] * phi[k * stride];
    g[i] = s;
    denom += phi[i * stride] * s;
    pred += phi[i * stride] * theta[i];
  }
  if (!(denom > 0.0) || !std::isfinite(denom)) return false;
  const double e = y - pred;
  const double inv = 1.0 / denom;
  double trace = 0.0;
  for (Eigen::Index i = 0; i < p; ++i) theta[i] += g[i] * inv * e;
  for (Eigen::Index c = 0; c < p; ++c) {
    for (Eigen::Index r = c; r < p; ++r) {
      const double v = pp[c * p + r] - g[r] * g[c] * inv;
      pp[c * p + r] = v;
      pp[r * p + c] = v;
    }
    trace += pp[c * p + c];
  }
  if (lambda != 1.0 && trace < max_trace) {
    const double scale = 1.0 / lambda;
    for (Eigen::Index i = 0; i < p * p; ++i) pp[i] *= scale;
  }
  return true;
}

}  // namespace detail

// Recursive least squares; reads forgetting and p0.
const EstimatorDescriptor& RlsDescriptor();

class Rls final : public Estimator {
 public:
  Rls(const Vec& theta0, double p0, double forgetting);
  const Mat* covariance_matrix() const override { return &p_; }
  std::string name() const override { return "rls"; }
  void Reset() override;

  // Update with one regression row φ (p entries, contiguous) and y: the same as Update(φᵀ, y) for a
  // 1 × p Φ, without the size checks or the virtual call (the identifier's per-sample path).
  // P = the parameter count when known at compile time (the loops unroll), else 0.
  template <int P = 0>
  void UpdateRow(const double* phi, double y) {
    const Eigen::Index p = P > 0 ? P : theta_.size();
    bool finite = std::isfinite(y);
    bool any = false;
    for (Eigen::Index i = 0; i < p; ++i) {
      finite = finite && std::isfinite(phi[i]);
      any = any || phi[i] != 0.0;
    }
    if (!Admit(finite)) return;
    ScalarUpdate<P>(phi, 1, y);
    CountExcitation(any ? 1 : 0);
  }

 private:
  void DoUpdate(const ConstMatRef& phi, const ConstVecRef& y) override;
  // Rows that carry information (φ ≠ 0) count towards excitation.
  void CountExcitation(long informative_rows) {
    rank_updates_ += informative_rows;
    if (status_ == EstimatorStatus::kNotExcited && rank_updates_ >= theta_.size()) {
      status_ = EstimatorStatus::kOk;
    }
  }
  // P as in UpdateRow; with P = 0 the parameter count picks a compile-time size when it has one.
  template <int P = 0>
  void ScalarUpdate(const double* phi, Eigen::Index stride, double y) {
    const Eigen::Index p = theta_.size();
    double* pp = p_.data();
    double* theta = theta_.data();
    double* g = work_.data();
    bool ok = false;
    if constexpr (P > 0) {
      ok = detail::ScalarRlsUpdate<P>(p, pp, theta, g, phi, stride, y, lambda_, max_trace_);
    } else {
      switch (p) {
        case 1: ok = detail::ScalarRlsUpdate<1>(p, pp, theta, g, phi, stride, y, lambda_, max_trace_); break;
        case 2: ok = detail::ScalarRlsUpdate<2>(p, pp, theta, g, phi, stride, y, lambda_, max_trace_); break;
        case 3: ok = detail::ScalarRlsUpdate<3>(p, pp, theta, g, phi, stride, y, lambda_, max_trace_); break;
        default: ok = detail::ScalarRlsUpdate<0>(p, pp, theta, g, phi, stride, y, lambda_, max_trace_); break;
      }
    }
    if (!ok) status_ = EstimatorStatus::kIllConditioned;
  }

  Mat p_;
  double p0_;
  double lambda_;
  double max_trace_;
  Vec work_;  // P φ for the scalar path
  long rank_updates_ = 0;
};

}  // namespace hysid
