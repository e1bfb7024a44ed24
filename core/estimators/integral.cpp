#include "core/estimators/integral.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include <Eigen/Cholesky>

namespace hysid {

IntegralLs::IntegralLs(const Vec& theta0, const Vec& p0_diagonal)
    : Estimator(theta0), ridge_(p0_diagonal.array().inverse()) {
  if (ridge_.size() != theta0.size()) {
    throw std::invalid_argument(fmt::format(
        "integral: P0 has {} diagonal entries; the estimator has {} parameters", ridge_.size(), theta0.size()));
  }
  Reset();
}

void IntegralLs::Reset() {
  const auto p = static_cast<std::size_t>(theta0_.size());
  a_closed_.assign(p * p, 0.0);
  b_closed_.assign(p, 0.0);
  m_.assign(p * p, 0.0);
  c_.assign(p, 0.0);
  a_.assign(p * p, 0.0);
  ldlt_.assign(p * p, 0.0);
  work_.assign(p, 0.0);
  covariance_ = Mat((0.5 * ridge_.array().inverse()).matrix().asDiagonal());
  covariance_stale_ = false;
  n_ = 0;
  rows_ = 0;
  informative_ = 0;
  ResetToPrior();
}

void IntegralLs::SetIllConditioned() {
  SetNotOk(EstimatorStatus::kIllConditioned, "the normal equations are not positive definite");
}

const Mat* IntegralLs::covariance_matrix() const {
  if (covariance_stale_) {
    const Eigen::Index p = theta0_.size();
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> a(
        a_.data(), p, p);
    covariance_ = 0.5 * a.llt().solve(Mat::Identity(p, p));
    covariance_stale_ = false;
  }
  return &covariance_;
}

bool IntegralLs::Excited() {
  const Eigen::Index p = theta0_.size();
  std::vector<double> b(static_cast<std::size_t>(p * p)), scale(static_cast<std::size_t>(p));
  for (Eigen::Index i = 0; i < p; ++i) {
    const double d = a_closed_[i * p + i] + m_[i * p + i];
    if (!(d > 0.0)) return false;
    scale[i] = 1.0 / std::sqrt(d);
  }
  for (Eigen::Index i = 0; i < p; ++i) {
    for (Eigen::Index j = 0; j < p; ++j)
      b[i * p + j] = (a_closed_[i * p + j] + m_[i * p + j]) * scale[i] * scale[j];
  }
  std::vector<double> v(static_cast<std::size_t>(p), 0.0);
  std::vector<double> keep = ldlt_;
  const bool ok = SolveLdlt(p, b.data(), v.data());
  bool full = ok;
  for (Eigen::Index i = 0; full && i < p; ++i) full = ldlt_[i * p + i] > 1e-10;
  ldlt_ = keep;
  return full;
}

bool IntegralLs::SolveLdlt(Eigen::Index p, const double* a, double* v) {
  // ldlt_: L below the diagonal (unit diagonal implied), D on it; row-major.
  double* l = ldlt_.data();
  for (Eigen::Index j = 0; j < p; ++j) {
    double d = a[j * p + j];
    for (Eigen::Index k = 0; k < j; ++k) d -= l[j * p + k] * l[j * p + k] * l[k * p + k];
    if (!(d > 0.0) || !std::isfinite(d)) return false;
    l[j * p + j] = d;
    for (Eigen::Index i = j + 1; i < p; ++i) {
      double sum = a[i * p + j];
      for (Eigen::Index k = 0; k < j; ++k) sum -= l[i * p + k] * l[j * p + k] * l[k * p + k];
      l[i * p + j] = sum / d;
    }
  }
  for (Eigen::Index i = 0; i < p; ++i) {
    for (Eigen::Index k = 0; k < i; ++k) v[i] -= l[i * p + k] * v[k];
  }
  for (Eigen::Index i = 0; i < p; ++i) v[i] /= l[i * p + i];
  for (Eigen::Index i = p; i-- > 0;) {
    for (Eigen::Index k = i + 1; k < p; ++k) v[i] -= l[k * p + i] * v[k];
  }
  return true;
}

void IntegralLs::Break() {
  if (n_ == 0) return;
  for (std::size_t i = 0; i < m_.size(); ++i) a_closed_[i] += m_[i];
  for (std::size_t i = 0; i < c_.size(); ++i) b_closed_[i] += c_[i];
  std::fill(m_.begin(), m_.end(), 0.0);
  std::fill(c_.begin(), c_.end(), 0.0);
  n_ = 0;
}

void IntegralLs::StartSegment(Eigen::Index rows) {
  Break();
  const auto size = static_cast<std::size_t>(rows * theta0_.size());
  cum_phi_.assign(size, 0.0);
  mean_phi_.assign(size, 0.0);
  cum_y_.assign(static_cast<std::size_t>(rows), 0.0);
  mean_y_.assign(static_cast<std::size_t>(rows), 0.0);
  rows_ = rows;
  n_ = 1;
}

void IntegralLs::DoUpdate(const ConstMatRef& phi, const ConstVecRef& y) {
  if (n_ == 0 || rows_ != phi.rows()) StartSegment(phi.rows());
  ++n_;
  for (Eigen::Index r = 0; r < phi.rows(); ++r) {
    AccumulateRow<0>(r, phi.data() + r, phi.outerStride(), y[r]);
    if (phi.row(r).any()) ++informative_;
  }
  Solve<0>();
}

EstimatorDescriptor IntegralDescriptor() {
  return {.name = "integral",
          .help = "least squares on integral rows, one offset per flow segment (alpha only)",
          .options = {"p0"},
          .traits = {.flow_only = true},
          .make = [](const EstimatorSettings& s, const Vec& theta0) -> std::unique_ptr<Estimator> {
            return std::make_unique<IntegralLs>(theta0, s.PriorCovariance(theta0.size()));
          }};
}

}  // namespace hysid
