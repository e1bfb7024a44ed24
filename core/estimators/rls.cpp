#include "core/estimators/rls.hpp"

#include <cmath>

#include <Eigen/Cholesky>

namespace hysid {

Rls::Rls(const Vec& theta0, double p0, double forgetting)
    : Estimator(theta0), theta0_(theta0), p0_(p0), lambda_(forgetting) {
  max_trace_ = p0_ * static_cast<double>(theta0.size());
  Reset();
}

void Rls::Reset() {
  theta_ = theta0_;
  p_ = p0_ * Mat::Identity(theta0_.size(), theta0_.size());
  work_.resize(theta0_.size());
  status_ = EstimatorStatus::kNotExcited;
  updates_ = 0;
  rank_updates_ = 0;
}

namespace {

// One scalar row, the common case (one identified state component). P = the parameter count when
// known at compile time (the loops unroll), or 0 for any p. `stride` is the distance between φ's
// entries: a 1×p row of a column-major matrix binds to ConstMatRef without a copy and then has
// outerStride() = the parent's row count. Returns false (nothing changed) when φᵀPφ + λ is not a
// positive finite number.
template <int P>
bool ScalarRlsUpdate(Eigen::Index p_dynamic, double* pp, double* theta, double* g,
                     const double* phi, Eigen::Index stride, double y, double lambda,
                     double max_trace) {
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

}  // namespace

void Rls::ScalarUpdate(const double* phi, Eigen::Index stride, double y) {
  const Eigen::Index p = theta_.size();
  double* pp = p_.data();
  double* theta = theta_.data();
  double* g = work_.data();
  bool ok = false;
  switch (p) {
    case 1: ok = ScalarRlsUpdate<1>(p, pp, theta, g, phi, stride, y, lambda_, max_trace_); break;
    case 2: ok = ScalarRlsUpdate<2>(p, pp, theta, g, phi, stride, y, lambda_, max_trace_); break;
    case 3: ok = ScalarRlsUpdate<3>(p, pp, theta, g, phi, stride, y, lambda_, max_trace_); break;
    default: ok = ScalarRlsUpdate<0>(p, pp, theta, g, phi, stride, y, lambda_, max_trace_); break;
  }
  if (!ok) status_ = EstimatorStatus::kIllConditioned;
}

void Rls::DoUpdate(ConstMatRef phi, ConstVecRef y) {
  if (phi.rows() == 1) {
    ScalarUpdate(phi.data(), phi.outerStride(), y[0]);
  } else {
    const Mat pphi_t = p_ * phi.transpose();                       // p × rows
    Mat gamma = phi * pphi_t;                                      // rows × rows
    gamma.diagonal().array() += lambda_;
    const Eigen::LLT<Mat> llt(gamma);
    if (llt.info() != Eigen::Success) {
      status_ = EstimatorStatus::kIllConditioned;
      return;
    }
    const Mat k = llt.solve(pphi_t.transpose()).transpose();  // p × rows
    theta_ += k * (y - phi * theta_);
    p_ -= k * pphi_t.transpose();
    p_ = 0.5 * (p_ + p_.transpose()).eval();
    if (lambda_ != 1.0 && p_.trace() < max_trace_) p_ /= lambda_;
  }
  // Rows that carry information (φ ≠ 0) count towards excitation.
  for (Eigen::Index r = 0; r < phi.rows(); ++r) rank_updates_ += phi.row(r).any() ? 1 : 0;
  if (status_ == EstimatorStatus::kNotExcited && rank_updates_ >= theta_.size()) {
    status_ = EstimatorStatus::kOk;
  }
}

}  // namespace hysid
