#include "core/estimators/rls.hpp"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include <Eigen/Cholesky>

namespace hysid {

Rls::Rls(const Vec& theta0, const Vec& p0_diagonal, double forgetting)
    : Estimator(theta0), p0_(p0_diagonal), lambda_(forgetting) {
  if (p0_.size() != theta0.size()) {
    throw std::invalid_argument(fmt::format("rls: P0 has {} diagonal entries; the estimator has {} parameters",
                                            p0_.size(), theta0.size()));
  }
  max_trace_ = p0_.sum();
  Reset();
}

void Rls::Reset() {
  p_ = p0_.asDiagonal();
  work_.resize(theta0_.size());
  ResetToPrior();
  rank_updates_ = 0;
}

void Rls::DoUpdate(const ConstMatRef& phi, const ConstVecRef& y) {
  if (phi.rows() == 1) {
    ScalarUpdate(phi.data(), phi.outerStride(), y[0]);
  } else {
    const Mat pphi_t = p_ * phi.transpose();  // p × rows
    Mat gamma = phi * pphi_t;                 // rows × rows
    gamma.diagonal().array() += lambda_;
    const Eigen::LLT<Mat> llt(gamma);
    if (llt.info() != Eigen::Success) {
      MarkIllConditioned();
      return;
    }
    const Mat k = llt.solve(pphi_t.transpose()).transpose();  // p × rows
    theta_ += k * (y - phi * theta_);
    p_ -= k * pphi_t.transpose();
    p_ = 0.5 * (p_ + p_.transpose()).eval();
    if (lambda_ != 1.0 && p_.trace() < max_trace_) p_ /= lambda_;
  }
  long informative = 0;
  for (Eigen::Index r = 0; r < phi.rows(); ++r) informative += phi.row(r).any() ? 1 : 0;
  CountExcitation(informative);
}

void Rls::MarkIllConditioned() {
  SetNotOk(EstimatorStatus::kIllConditioned,
           "an update was skipped: the innovation covariance lambda + phi P phi' was not positive and finite");
}

EstimatorDescriptor RlsDescriptor() {
  return {.name = "rls",
          .help = "recursive least squares",
          .options = {"forgetting", "p0"},
          .make = [](const EstimatorSettings& s, const Vec& theta0) -> std::unique_ptr<Estimator> {
            return std::make_unique<Rls>(theta0, s.PriorCovariance(theta0.size()), s.forgetting);
          }};
}

}  // namespace hysid
