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

// Two-parameter RLS on one scalar row, in scalars: P = [[p00, p10], [p10, p11]] (P stays symmetric:
// every update writes both off-diagonal entries from one value), θ = (t0, t1). A loop that keeps it
// in local variables across rows (the identifier's per-sample path) and ScalarRlsUpdate<2> share
// this arithmetic, so both give the same bits.
struct Rls2State {
  double t0, t1, p00, p10, p11;

  // From and to θ (2 entries) and P (2 × 2, column-major).
  static Rls2State Load(const double* theta, const double* pp) {
    return {theta[0], theta[1], pp[0], pp[1], pp[3]};
  }
  void Store(double* theta, double* pp) const {
    theta[0] = t0;
    theta[1] = t1;
    pp[0] = p00;
    pp[1] = pp[2] = p10;
    pp[3] = p11;
  }

  // ScalarRlsUpdate's steps for p = 2; false (nothing changed) when φᵀPφ + λ is not a positive
  // finite number. Pφ there is 0 + p·f + p·f, whose leading 0 turns an exact −0 into +0; since
  // (0 + a) + b = (a + b) + 0 in every case and φᵀPφ + λ only sees the sign of a zero entry of Pφ
  // when it is zero itself (and then fails), the loop-carried chain P → Pφ → φᵀPφ + λ → P takes
  // a + b and the + 0 is added beside it: the same bits, one addition fewer on the chain.
  [[gnu::always_inline]] bool Update(double f0, double f1, double y, double lambda, double max_trace) {
    const double h0 = p00 * f0 + p10 * f1, h1 = p10 * f0 + p11 * f1;
    double denom = lambda, pred = 0.0;
    denom += f0 * h0;
    pred += f0 * t0;
    denom += f1 * h1;
    pred += f1 * t1;
    if (!(denom > 0.0) || !std::isfinite(denom)) return false;
    const double g0 = h0 + 0.0, g1 = h1 + 0.0;
    const double e = y - pred;
    const double inv = 1.0 / denom;
    t0 += g0 * inv * e;
    t1 += g1 * inv * e;
    p00 = p00 - g0 * g0 * inv;
    p10 = p10 - g1 * g0 * inv;
    p11 = p11 - g1 * g1 * inv;
    double trace = 0.0;
    trace += p00;
    trace += p11;
    if (lambda != 1.0 && trace < max_trace) {
      const double scale = 1.0 / lambda;
      p00 *= scale;
      p10 *= scale;
      p11 *= scale;
    }
    return true;
  }
};

// One scalar row, the common case (one identified state component). P = the parameter count when
// known at compile time (the loops unroll), or 0 for any p. `stride` is the distance between φ's
// entries: a 1×p row of a column-major matrix binds to ConstMatRef without a copy and then has
// outerStride() = the parent's row count. Returns false (nothing changed) when φᵀPφ + λ is not a
// positive finite number.
template <int P>
inline bool ScalarRlsUpdate(Eigen::Index p_dynamic, double* pp, double* theta, double* g, const double* phi,
                            Eigen::Index stride, double y, double lambda, double max_trace) {
  if constexpr (P == 2) {
    Rls2State r = Rls2State::Load(theta, pp);
    if (!r.Update(phi[0], phi[stride], y, lambda, max_trace)) return false;
    r.Store(theta, pp);
    return true;
  }
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
EstimatorDescriptor RlsDescriptor();

class Rls final : public Estimator {
 public:
  // P0 = diag(p0_diagonal) (PriorCovariance).
  Rls(const Vec& theta0, const Vec& p0_diagonal, double forgetting);
  const Mat* covariance_matrix() const override { return &p_; }
  std::string name() const override { return "rls"; }
  std::unique_ptr<Estimator> Clone() const override { return std::make_unique<Rls>(*this); }
  void Reset() override;

  // Update with one regression row φ (p entries, contiguous) and y: the same as Update(φᵀ, y) for a
  // 1 × p Φ, without the size checks or the virtual call (the identifier's per-sample path).
  // P = the parameter count when known at compile time (the loops unroll), else 0.
  template <int P = 0>
  void UpdateRow(const double* phi, double y) {
    AdmitRow<P>(phi, y, [&] { ScalarUpdate<P>(phi, 1, y); });
  }

  // Two parameters only: θ and P as scalars (Load2), updated by UpdateRowIn with UpdateRow<2>'s
  // arithmetic while the caller keeps them in local variables, and written back by Store2 before
  // anything else reads the estimate or the covariance. The counters and the status stay in the
  // object.
  detail::Rls2State Load2() const { return detail::Rls2State::Load(theta_.data(), p_.data()); }
  void Store2(const detail::Rls2State& r) { r.Store(theta_.data(), p_.data()); }
  [[gnu::always_inline]] void UpdateRowIn(detail::Rls2State& r, const double* phi, double y) {
    AdmitRow<2>(phi, y, [&] {
      if (!r.Update(phi[0], phi[1], y, lambda_, max_trace_)) MarkIllConditioned();
    });
  }
  // A loop that applies r.Update itself (to finite rows whose updates succeeded) reads λ and the
  // wind-up bound here, and counts its rows afterwards: `admitted` rows, `informative` of them with
  // φ ≠ 0 (the same counters and status as UpdateRowIn on each).
  double forgetting() const { return lambda_; }
  double max_trace() const { return max_trace_; }
  void CountRowsIn(long admitted, long informative) {
    AddUpdates(admitted);
    CountExcitation(informative);
  }

 private:
  // A row that is not finite is skipped (counted); otherwise `update` runs and the row counts
  // towards excitation when φ ≠ 0.
  template <int P, class F>
  [[gnu::always_inline]] void AdmitRow(const double* phi, double y, F&& update) {
    const Eigen::Index p = P > 0 ? P : theta_.size();
    bool finite = std::isfinite(y);
    bool any = false;
    for (Eigen::Index i = 0; i < p; ++i) {
      finite = finite && std::isfinite(phi[i]);
      any = any || phi[i] != 0.0;
    }
    if (!Admit(finite)) return;
    update();
    CountExcitation(any ? 1 : 0);
  }
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
    if (!ok) MarkIllConditioned();
  }
  // An update skipped: φᵀPφ + λ (or the innovation covariance) was not a positive finite number.
  void MarkIllConditioned();

  Mat p_;
  Vec p0_;  // P0's diagonal
  double lambda_;
  double max_trace_;
  Vec work_;  // P φ for the scalar path
  long rank_updates_ = 0;
};

}  // namespace hysid
