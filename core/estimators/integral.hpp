// Least squares on integral rows with one offset per flow segment (`integral`), for α only.
//
// The identifier's flow rows are consecutive trapezoid differences y_k = ξ_k − ξ_{k−1} (identified
// rows) with Φ_k = (δt/2)(φ(ξ_k) + φ(ξ_{k−1})) (known parameters moved to y). Within one flow
// segment (between jumps, gaps or the start: Break()) their running sums telescope:
//   z_k = Σ_{i≤k} y_i = ξ_k − ξ_a,   I_k = Σ_{i≤k} Φ_i ≈ ∫_{t_a}^{t_k} φ(ξ) dt,   z_k = I_k α,
// so every sample ξ_k is a measurement of the integral with its own noise only; the segment's start
// sample ξ_a, whose noise all rows of the segment share, is an unknown offset c per identified row:
// ξ_{k,r} = c_r + I_{k,r} α. Eliminating c_r (centring z and I over the segment's samples, anchor
// included) leaves the normal equations
//   A = Σ_segments Σ_r Σ_k (I_k − Ī)(I_k − Ī)ᵀ,   b = Σ … (I_k − Ī)(z_k − z̄),
//   α̂ = (A + I/p0)⁻¹ (b + α0/p0),
// accumulated with Welford's centred updates (with d = I_k − Ī_{k−1}: M += (1 − 1/n) d dᵀ) and
// solved after every row (closed form for p = 2, LDLᵀ otherwise). Consecutive-sample rows lose the
// information of every sample between a segment's ends (their noise telescopes away and only the
// two end samples remain); these rows keep it: on the §5 system the mean e_α is 3.7 times the
// Cramér–Rao-implied value, where rls on the same rows is 22–93 times (docs/results.md).
// The rows must be the consecutive differences of one trajectory, so this estimator is for α only
// (its descriptor's flow_only; as the β estimator rls is used). covariance_matrix() is A⁻¹/2: the
// covariance of α̂ in units of one trapezoid row's residual variance (2σ² for white noise σ²), the
// scale the detectors multiply it by. The status is not-excited until p + 1 rows with Φ ≠ 0 have
// come and the centred information has full rank.
#pragma once

#include <cmath>
#include <vector>

#include "core/estimators/estimator.hpp"

namespace hysid {

// Integral-row least squares; reads p0.
EstimatorDescriptor IntegralDescriptor();

class IntegralLs final : public Estimator {
 public:
  // The prior ridge diag(1/p0_diagonal) (PriorCovariance).
  IntegralLs(const Vec& theta0, const Vec& p0_diagonal);
  const Mat* covariance_matrix() const override;
  std::string name() const override { return "integral"; }
  std::unique_ptr<Estimator> Clone() const override { return std::make_unique<IntegralLs>(*this); }
  void Reset() override;
  void Break() override;

  // Update with one regression row φ (p entries, contiguous) and y: the same as Update(φᵀ, y) for a
  // 1 × p Φ, without the size checks or the virtual call (the identifier's per-sample path).
  // P = the parameter count when known at compile time (the loops unroll), else 0.
  template <int P = 0>
  void UpdateRow(const double* phi, double y) {
    const Eigen::Index p = P > 0 ? P : theta_.size();
    bool finite = std::isfinite(y), any = false;
    for (Eigen::Index i = 0; i < p; ++i) {
      finite = finite && std::isfinite(phi[i]);
      any = any || phi[i] != 0.0;
    }
    if (!Admit(finite)) return;
    if (n_ == 0 || rows_ != 1) StartSegment(1);
    ++n_;
    if constexpr (P == 2) {
      const Moments2 mc = AccumulateRow2(0, phi, 1, y);
      if (any) ++informative_;
      Solve2(mc);
    } else {
      AccumulateRow<P>(0, phi, 1, y);
      if (any) ++informative_;
      Solve<P>();
    }
  }

 private:
  void DoUpdate(const ConstMatRef& phi, const ConstVecRef& y) override;
  // The segment's anchor ξ_a (I = 0, z = 0) as its first sample.
  void StartSegment(Eigen::Index rows);

  // Row r of the n_-th sample: the running sums, their means and the co-moments M, c.
  template <int P>
  void AccumulateRow(Eigen::Index r, const double* phi, Eigen::Index stride, double y) {
    const Eigen::Index p = P > 0 ? P : theta_.size();
    double* cum = cum_phi_.data() + r * p;
    double* mean = mean_phi_.data() + r * p;
    // d in registers when p is known at compile time (a scalar store read back as a vector would
    // not be forwarded).
    double d_local[P > 0 ? P : 1];
    double* d = P > 0 ? d_local : work_.data();
    const double w = 1.0 / static_cast<double>(n_), keep = 1.0 - w;
    for (Eigen::Index i = 0; i < p; ++i) {
      cum[i] += phi[i * stride];
      d[i] = cum[i] - mean[i];
      mean[i] += w * d[i];
    }
    cum_y_[r] += y;
    const double dz = cum_y_[r] - mean_y_[r];
    mean_y_[r] += w * dz;
    for (Eigen::Index i = 0; i < p; ++i) {
      for (Eigen::Index j = 0; j < p; ++j) m_[i * p + j] += keep * d[i] * d[j];
      c_[i] += keep * d[i] * dz;
    }
  }
  // M's entries 0, 1 (= 2) and 3 and c, for p = 2.
  struct Moments2 {
    double m0, m1, m3, c0, c1;
  };
  // AccumulateRow for p = 2, the same arithmetic with d and the updated M and c in scalars, handed to
  // Solve2 in registers: GCC may read a two-entry d array, or M and c right after their scalar stores,
  // back as vectors, which those stores do not forward (a stall that doubled the integral step).
  Moments2 AccumulateRow2(Eigen::Index r, const double* phi, Eigen::Index stride, double y) {
    double* cum = cum_phi_.data() + r * 2;
    double* mean = mean_phi_.data() + r * 2;
    const double w = 1.0 / static_cast<double>(n_), keep = 1.0 - w;
    cum[0] += phi[0];
    const double d0 = cum[0] - mean[0];
    mean[0] += w * d0;
    cum[1] += phi[stride];
    const double d1 = cum[1] - mean[1];
    mean[1] += w * d1;
    cum_y_[r] += y;
    const double dz = cum_y_[r] - mean_y_[r];
    mean_y_[r] += w * dz;
    const Moments2 mc{.m0 = m_[0] + keep * d0 * d0,
                      .m1 = m_[1] + keep * d0 * d1,
                      .m3 = m_[3] + keep * d1 * d1,
                      .c0 = c_[0] + keep * d0 * dz,
                      .c1 = c_[1] + keep * d1 * dz};
    const double m2 = m_[2] + keep * d1 * d0;
    m_[0] = mc.m0, m_[1] = mc.m1, m_[2] = m2, m_[3] = mc.m3;
    c_[0] = mc.c0, c_[1] = mc.c1;
    return mc;
  }

  // α̂ = (A + I/p0)⁻¹(b + α0/p0): for p = 2 in closed form (one division), else by an LDLᵀ
  // factorisation (no square roots); A + I/p0 is kept for the covariance A⁻¹/2, computed when
  // asked. A matrix that is not positive definite leaves α̂ and sets kIllConditioned.
  template <int P>
  void Solve() {
    if (P == 2 || (P == 0 && theta_.size() == 2)) {  // the same arithmetic as the direct path
      return Solve2({.m0 = m_[0], .m1 = m_[1], .m3 = m_[3], .c0 = c_[0], .c1 = c_[1]});
    }
    const Eigen::Index p = P > 0 ? P : theta_.size();
    double* a = a_.data();
    double* v = work_.data();
    for (Eigen::Index i = 0; i < p * p; ++i) a[i] = a_closed_[i] + m_[i];
    for (Eigen::Index i = 0; i < p; ++i) {
      a[i * p + i] += ridge_[i];
      v[i] = b_closed_[i] + c_[i] + ridge_[i] * theta0_[i];
    }
    const bool ok = SolveLdlt(p, a, v);
    if (ok) {
      for (Eigen::Index i = 0; i < p; ++i) theta_[i] = v[i];
    }
    Solved(ok, p);
  }
  // Solve for p = 2 in closed form from the open segment's M and c.
  void Solve2(const Moments2& mc) {
    double* a = a_.data();
    const double a0 = a_closed_[0] + mc.m0 + ridge_[0], a1 = a_closed_[1] + mc.m1;
    const double a3 = a_closed_[3] + mc.m3 + ridge_[1];
    const double v0 = b_closed_[0] + mc.c0 + ridge_[0] * theta0_[0];
    const double v1 = b_closed_[1] + mc.c1 + ridge_[1] * theta0_[1];
    a[0] = a0, a[1] = a[2] = a1, a[3] = a3;
    const double det = a0 * a3 - a1 * a1;
    const bool ok = a0 > 0.0 && det > 0.0 && std::isfinite(det);
    if (ok) {
      const double inv = 1.0 / det;
      theta_[0] = (a3 * v0 - a1 * v1) * inv;
      theta_[1] = (a0 * v1 - a1 * v0) * inv;
    }
    Solved(ok, 2);
  }
  // After a solve: kIllConditioned when it failed, else the covariance stale and the status ok once
  // excited.
  void Solved(bool ok, Eigen::Index p) {
    if (!ok) {
      SetIllConditioned();
      return;
    }
    covariance_stale_ = true;
    if (status_ == EstimatorStatus::kNotExcited && informative_ > p && Excited())
      status_ = EstimatorStatus::kOk;
  }
  // Whether the centred information A (without the prior ridge) has full rank: every diagonal entry
  // positive and every LDLᵀ pivot of the correlation matrix D^{-1/2} A D^{-1/2} above 1e-10.
  bool Excited();
  // Solves (row-major p × p, symmetric positive definite) a x = v in place of v by LDLᵀ; false when
  // a pivot is not a positive finite number.
  bool SolveLdlt(Eigen::Index p, const double* a, double* v);
  // kIllConditioned with its reason. Out of line: the reason's string would keep Solve, and with it
  // the per-sample UpdateRow, from being inlined.
  void SetIllConditioned();

  Vec ridge_;  // 1/P0's diagonal
  // Closed segments: A and b (centred, offsets eliminated); p × p row-major, p.
  std::vector<double> a_closed_, b_closed_;
  // The open segment: samples so far (anchor included; 0 = none open), its identified rows, the
  // running sums I (rows × p, row-major) and z (rows), their means over the segment's samples, and
  // the co-moments M = Σ(I − Ī)(I − Ī)ᵀ (p × p) and c = Σ(I − Ī)(z − z̄), summed over the rows.
  long n_ = 0;
  Eigen::Index rows_ = 0;
  std::vector<double> cum_phi_, mean_phi_, cum_y_, mean_y_, m_, c_;
  std::vector<double> a_, work_, ldlt_;  // A + I/p0 of the last solve (row-major), work space
  mutable Mat covariance_;
  mutable bool covariance_stale_ = false;
  long informative_ = 0;  // rows with Φ ≠ 0
};

}  // namespace hysid
