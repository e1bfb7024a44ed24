#include "core/estimators/rls.hpp"

#include <cmath>

#include <Eigen/Cholesky>

namespace hysid {

Rls::Rls(const Vec& theta0, double p0, double forgetting) : Estimator(theta0), p0_(p0), lambda_(forgetting) {
  max_trace_ = p0_ * static_cast<double>(theta0.size());
  Reset();
}

void Rls::Reset() {
  p_ = p0_ * Mat::Identity(theta0_.size(), theta0_.size());
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
      status_ = EstimatorStatus::kIllConditioned;
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

EstimatorDescriptor RlsDescriptor() {
  return {.name = "rls",
          .help = "recursive least squares",
          .options = {"forgetting", "p0"},
          .make = [](const EstimatorSettings& s, const Vec& theta0) -> std::unique_ptr<Estimator> {
            return std::make_unique<Rls>(theta0, s.p0, s.forgetting);
          }};
}

}  // namespace hysid
