#include "core/estimators/frisch.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <fmt/format.h>

namespace hysid {
namespace {

constexpr double kPivotTolerance = 1e-12;
constexpr double kInfiniteVertex = 1e-12;

}  // namespace

Frisch::Frisch(const Vec& theta0, int window, double forgetting, double p0, FrischBox box,
               FrischPoint point)
    : Estimator(theta0),
      theta0_(theta0),
      window_(window),
      lambda_(forgetting),
      box_rule_(box),
      point_rule_(point),
      rls_(theta0, p0, forgetting) {
  const long m = theta0.size() + 1;
  if (window < 0 || (window > 0 && window < m)) {
    throw std::invalid_argument(fmt::format(
        "frisch: window = {}: must be 0 (growing) or >= parameters + 1 = {}", window, m));
  }
  if (!(forgetting > 0.0 && forgetting <= 1.0)) {
    throw std::invalid_argument(
        fmt::format("frisch: forgetting = {}: must be in (0, 1]", forgetting));
  }
  Reset();
}

void Frisch::Reset() {
  const Eigen::Index p = theta0_.size();
  const Eigen::Index m = p + 1;
  theta_ = theta0_;
  rls_.Reset();
  block_sigma_ = Mat::Zero(m, m);
  all_sigma_ = Mat::Zero(m, m);
  vertices_ = Mat::Zero(p, m);
  work_inverse_ = Mat::Zero(m, m);
  lower_ = theta0_;
  upper_ = theta0_;
  inter_lower_ = inter_upper_ = cum_lower_ = cum_upper_ = theta0_;
  has_inter_ = has_cum_ = false;
  window_lower_ = Vec::Zero(p);
  window_upper_ = Vec::Zero(p);
  scale_ = Vec::Ones(m);
  rows_in_block_ = 0;
  rows_ = 0;
  windows_ = 0;
  skipped_windows_ = 0;
  empty_intersections_ = 0;
  has_box_ = false;
  kalman_ = false;
  status_ = EstimatorStatus::kNotExcited;
  updates_ = 0;
  skipped_ = 0;
}

bool Frisch::Contains(ConstVecRef theta, double tolerance) const {
  if (!has_box_ || theta.size() != lower_.size()) return false;
  for (Eigen::Index i = 0; i < theta.size(); ++i) {
    if (theta[i] < lower_[i] - tolerance || theta[i] > upper_[i] + tolerance) return false;
  }
  return true;
}

double Frisch::BoxVolume() const {
  if (!has_box_) return 0.0;
  return (upper_ - lower_).prod();
}

bool Frisch::WindowBox(const Mat& sigma, VecRef lower, VecRef upper) {
  const Eigen::Index m = sigma.rows();
  const Eigen::Index p = m - 1;
  for (Eigen::Index i = 0; i < m; ++i) {
    const double d = sigma(i, i);
    if (!(d > 0.0) || !std::isfinite(d)) return false;  // zero column
    scale_[i] = 1.0 / std::sqrt(d);
  }
  const Mat sd = scale_.asDiagonal() * sigma * scale_.asDiagonal();
  const Eigen::LLT<Mat> llt(sd);
  if (llt.info() != Eigen::Success) return false;
  const Mat& l = llt.matrixLLT();
  for (Eigen::Index i = 0; i < m; ++i) {
    if (!(l(i, i) * l(i, i) >= kPivotTolerance)) return false;  // singular: collinear or exact
  }
  work_inverse_ = llt.solve(Mat::Identity(m, m));  // (DΣD)⁻¹; the vertices are scale-free per
                                                   // column up to D, undone below
  // Σ⁻¹ = D (DΣD)⁻¹ D; vertex i: θ_i = −(Σ⁻¹)_{0:p,i}/(Σ⁻¹)_{p,i} = −D_{0:p}(W)_{0:p,i}/(D_p W_{p,i}).
  for (Eigen::Index i = 0; i < m; ++i) {
    const double den = work_inverse_(p, i);
    const double size = std::sqrt(std::abs(work_inverse_(i, i) * work_inverse_(p, p)));
    if (!(std::abs(den) > kInfiniteVertex * size)) return false;  // vertex at infinity
    for (Eigen::Index j = 0; j < p; ++j) {
      vertices_(j, i) = -scale_[j] * work_inverse_(j, i) / (scale_[p] * den);
    }
  }
  lower = vertices_.rowwise().minCoeff();
  upper = vertices_.rowwise().maxCoeff();
  // Kalman's condition: D Σ⁻¹ D > 0 element-wise with D = diag(sign(Σ⁻¹ e_p)) (D > 0 is harmless).
  kalman_ = true;
  for (Eigen::Index i = 0; i < m && kalman_; ++i) {
    for (Eigen::Index j = 0; j < m && kalman_; ++j) {
      const double si = work_inverse_(i, p) >= 0.0 ? 1.0 : -1.0;
      const double sj = work_inverse_(j, p) >= 0.0 ? 1.0 : -1.0;
      kalman_ = si * sj * work_inverse_(i, j) > 0.0;
    }
  }
  return lower.allFinite() && upper.allFinite();
}

void Frisch::TakeWindow(const Mat& block, const Mat& all) {
  // Both boxes are kept: the BBRF intersection (of the block boxes) and the cumulative box. The one
  // selected by frisch_box is computed last, so vertices() and kalman_condition() describe it.
  const bool intersect_last = box_rule_ == FrischBox::kIntersect;
  for (int pass = 0; pass < 2; ++pass) {
    const bool intersect = (pass == 1) == intersect_last;
    if (!WindowBox(intersect ? block : all, window_lower_, window_upper_)) {
      if (pass == 1) ++skipped_windows_;
      continue;
    }
    if (pass == 1) ++windows_;
    if (!intersect) {
      cum_lower_ = window_lower_;
      cum_upper_ = window_upper_;
      has_cum_ = true;
    } else if (!has_inter_) {
      inter_lower_ = window_lower_;
      inter_upper_ = window_upper_;
      has_inter_ = true;
    } else {
      const Vec new_lower = inter_lower_.cwiseMax(window_lower_);
      const Vec new_upper = inter_upper_.cwiseMin(window_upper_);
      if ((new_lower.array() > new_upper.array()).any()) {
        ++empty_intersections_;  // BBRF fallback: keep the previous box
      } else {
        inter_lower_ = new_lower;
        inter_upper_ = new_upper;
      }
    }
  }
  if (intersect_last ? has_inter_ : has_cum_) {
    lower_ = intersect_last ? inter_lower_ : cum_lower_;
    upper_ = intersect_last ? inter_upper_ : cum_upper_;
    has_box_ = true;
  }
}

void Frisch::SetPoint() {
  if (!has_box_) {
    theta_ = rls_.estimate();
    status_ = EstimatorStatus::kNotExcited;
    return;
  }
  if (point_rule_ == FrischPoint::kCentre) {
    theta_ = 0.5 * (lower_ + upper_);
  } else {
    const Vec& lo = has_inter_ ? inter_lower_ : lower_;
    const Vec& up = has_inter_ ? inter_upper_ : upper_;
    theta_ = rls_.estimate().cwiseMax(lo).cwiseMin(up);
  }
  status_ = EstimatorStatus::kOk;
}

void Frisch::DoUpdate(ConstMatRef phi, ConstVecRef y) {
  rls_.Update(phi, y);
  const Eigen::Index p = phi.cols();
  const Eigen::Index m = p + 1;
  const Eigen::Index rows = phi.rows();
  bool any = false;
  for (Eigen::Index r = 0; r < rows && !any; ++r) any = phi.row(r).any() || y[r] != 0.0;
  if (any && lambda_ != 1.0) all_sigma_ *= lambda_;
  double* block = block_sigma_.data();
  double* all = all_sigma_.data();
  for (Eigen::Index r = 0; r < rows; ++r) {
    for (Eigen::Index c = 0; c < m; ++c) {
      const double zc = c < p ? phi(r, c) : y[r];
      for (Eigen::Index i = c; i < m; ++i) {
        const double zi = i < p ? phi(r, i) : y[r];
        block[c * m + i] += zi * zc;
        all[c * m + i] += zi * zc;
      }
    }
    ++rows_;
    ++rows_in_block_;
    if (window_ > 0 && rows_in_block_ >= window_) {
      // Only the lower triangles were accumulated.
      TakeWindow(block_sigma_.selfadjointView<Eigen::Lower>(),
                 all_sigma_.selfadjointView<Eigen::Lower>());
      block_sigma_.setZero();
      rows_in_block_ = 0;
    }
  }
  if (window_ == 0 && rows_ >= m) {
    // Growing window: the "blocks" are the successive cumulative matrices.
    const Mat all = all_sigma_.selfadjointView<Eigen::Lower>();
    TakeWindow(all, all);
  }
  SetPoint();
}

}  // namespace hysid
