#include "core/estimators/frisch.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <numbers>

#include <Eigen/Cholesky>
#include <fmt/format.h>

#include "core/stats/quantiles.hpp"

namespace hysid {

Mat Frisch::solution_box() const {
  if (!has_box_) return Mat();
  Mat box(lower_.size(), 2);
  box.col(0) = lower_;
  box.col(1) = upper_;
  return box;
}
namespace {

constexpr double kPivotTolerance = 1e-12;
constexpr double kInfiniteVertex = 1e-12;

}  // namespace

Frisch::Frisch(const Vec& theta0, int window, double forgetting, const Vec& p0_diagonal, FrischBox box, FrischPoint point,
               const Mat& noise_shape, double confidence)
    : Estimator(theta0),
      window_(window),
      lambda_(forgetting),
      confidence_(confidence),
      box_rule_(box),
      point_rule_(point),
      rls_(theta0, p0_diagonal, forgetting) {
  const long m = theta0.size() + 1;
  if (window < 0 || (window > 0 && window < m)) {
    throw std::invalid_argument(
        fmt::format("frisch: window = {}: must be 0 (growing) or >= parameters + 1 = {}", window, m));
  }
  if (!(forgetting > 0.0 && forgetting <= 1.0)) {
    throw std::invalid_argument(fmt::format("frisch: forgetting = {}: must be in (0, 1]", forgetting));
  }
  if (!(confidence >= 0.0 && confidence < 1.0)) {
    throw std::invalid_argument(fmt::format("frisch: confidence = {}: must be in [0, 1)", confidence));
  }
  if (noise_shape.size() != 0) {
    if (noise_shape.rows() != m || noise_shape.cols() != m) {
      throw std::invalid_argument(fmt::format("frisch: noise_shape is {}x{}, expected {}x{} (parameters + 1)",
                                              noise_shape.rows(), noise_shape.cols(), m, m));
    }
    if (!noise_shape.allFinite() || (noise_shape.diagonal().array() < 0.0).any()) {
      throw std::invalid_argument("frisch: noise_shape must be finite with a diagonal >= 0");
    }
    for (Eigen::Index i = 0; i < m; ++i) {
      if (noise_shape(i, i) > 0.0) noisy_.push_back(i);
    }
  }
  if (noisy_.empty()) {  // no shape, or no noise anywhere: every column may carry noise
    for (Eigen::Index i = 0; i < m; ++i) noisy_.push_back(i);
  }
  Reset();
}

void Frisch::Reset() {
  ResetToPrior();
  const Eigen::Index p = theta0_.size();
  const Eigen::Index m = p + 1;
  rls_.Reset();
  block_sigma_ = Mat::Zero(m, m);
  all_sigma_ = Mat::Zero(m, m);
  vertices_ = Mat::Zero(p, static_cast<Eigen::Index>(noisy_.size()));
  work_inverse_ = Mat::Zero(m, m);
  lower_ = theta0_;
  upper_ = theta0_;
  inter_lower_ = inter_upper_ = cum_lower_ = cum_upper_ = theta0_;
  has_inter_ = has_cum_ = false;
  window_lower_ = Vec::Zero(p);
  window_upper_ = Vec::Zero(p);
  scale_ = Vec::Ones(m);
  rows_in_block_ = 0;
  all_weight_ = 0.0;
  blocks_ = 0;
  cum_dof_ = 0.0;
  cum_quantile_ = 0.0;
  rows_ = 0;
  windows_ = 0;
  skipped_windows_ = 0;
  empty_intersections_ = 0;
  has_box_ = false;
  kalman_ = false;
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

bool Frisch::WindowBox(const Mat& sigma, double count, double quantile, VecRef lower, VecRef upper) {
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
  // Only the columns that may carry noise give vertices (exact columns: the face, see frisch.hpp).
  for (std::size_t k = 0; k < noisy_.size(); ++k) {
    const Eigen::Index i = noisy_[k];
    const auto col = static_cast<Eigen::Index>(k);
    const double den = work_inverse_(p, i);
    const double size = std::sqrt(std::abs(work_inverse_(i, i) * work_inverse_(p, p)));
    if (!(std::abs(den) > kInfiniteVertex * size)) return false;  // vertex at infinity
    for (Eigen::Index j = 0; j < p; ++j) {
      vertices_(j, col) = -scale_[j] * work_inverse_(j, i) / (scale_[p] * den);
    }
  }
  lower = vertices_.rowwise().minCoeff();
  upper = vertices_.rowwise().maxCoeff();
  if (quantile > 0.0 && count > double(p)) {
    // Sampling allowance: ± quantile × the standard error of the least-squares vertex. With
    // Σ⁻¹ = D W D, RSS = 1/(Σ⁻¹)_pp (Schur complement), (Σ_φφ⁻¹)_jj = (Σ⁻¹)_jj − (Σ⁻¹)_jp²/(Σ⁻¹)_pp.
    const double ipp = scale_[p] * scale_[p] * work_inverse_(p, p);
    const double s2 = 1.0 / ipp / (count - double(p));
    for (Eigen::Index j = 0; j < p; ++j) {
      const double ijj = scale_[j] * scale_[j] * work_inverse_(j, j);
      const double ijp = scale_[j] * scale_[p] * work_inverse_(j, p);
      const double var = s2 * std::max(0.0, ijj - ijp * ijp / ipp);
      const double half = quantile * std::sqrt(var);
      lower[j] -= half;
      upper[j] += half;
    }
  }
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

double Frisch::CumulativeQuantile(double dof) {
  // t quantiles fall with the degrees of freedom, so the one at a smaller dof is conservative:
  // recomputed only when dof has doubled (O(log N) evaluations of ~25 µs each).
  dof = std::max(1.0, dof);
  if (cum_quantile_ == 0.0 || dof >= 2.0 * cum_dof_) {
    cum_dof_ = dof;
    cum_quantile_ = StudentUpperQuantile(0.5 * (1.0 - confidence_), dof);
  }
  return cum_quantile_;
}

void Frisch::TakeWindow(const Mat& block, double block_count, const Mat& all, double all_count) {
  // Both boxes are kept: the BBRF intersection (of the block boxes) and the cumulative box. The one
  // selected by frisch_box is computed last, so vertices() and kalman_condition() describe it.
  const double p = double(theta0_.size());
  const bool sampled = confidence_ > 0.0;
  if (window_ == 0) {
    // The growing window has no disjoint blocks to intersect: one box, reported by both rules.
    const double q = sampled ? CumulativeQuantile(all_count - p) : 0.0;
    if (!WindowBox(all, all_count, q, window_lower_, window_upper_)) {
      ++skipped_windows_;
    } else {
      ++windows_;
      cum_lower_ = inter_lower_ = window_lower_;
      cum_upper_ = inter_upper_ = window_upper_;
      has_cum_ = has_inter_ = true;
    }
  }
  const bool intersect_last = box_rule_ == FrischBox::kIntersect;
  for (int pass = 0; pass < 2 && window_ > 0; ++pass) {
    const bool intersect = (pass == 1) == intersect_last;
    double q = 0.0;
    if (sampled && intersect) {
      // Union bound over the blocks: block k gets level (1 − confidence)·6/(π²k²), Σ_k = 1 − c.
      ++blocks_;
      const double k = double(blocks_);
      const double level = (1.0 - confidence_) * 6.0 / (std::numbers::pi * std::numbers::pi * k * k);
      q = StudentUpperQuantile(0.5 * level, std::max(1.0, block_count - p));
    } else if (sampled) {
      q = CumulativeQuantile(all_count - p);
    }
    if (!WindowBox(intersect ? block : all, intersect ? block_count : all_count, q, window_lower_,
                   window_upper_)) {
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
    theta_ = theta_.cwiseMax(lower_).cwiseMin(upper_);  // inside the reported box as well
  }
  status_ = EstimatorStatus::kOk;
}

void Frisch::DoUpdate(const ConstMatRef& phi, const ConstVecRef& y) {
  rls_.Update(phi, y);
  const Eigen::Index p = phi.cols();
  const Eigen::Index m = p + 1;
  const Eigen::Index rows = phi.rows();
  bool any = false;
  for (Eigen::Index r = 0; r < rows && !any; ++r) any = phi.row(r).any() || y[r] != 0.0;
  if (any && lambda_ != 1.0) {
    all_sigma_ *= lambda_;
    all_weight_ *= lambda_;
  }
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
    all_weight_ += 1.0;
    if (window_ > 0 && rows_in_block_ >= window_) {
      // Only the lower triangles were accumulated.
      TakeWindow(block_sigma_.selfadjointView<Eigen::Lower>(), double(rows_in_block_),
                 all_sigma_.selfadjointView<Eigen::Lower>(), all_weight_);
      block_sigma_.setZero();
      rows_in_block_ = 0;
    }
  }
  if (window_ == 0 && rows_ >= m) {
    // Growing window: the "blocks" are the successive cumulative matrices.
    const Mat all = all_sigma_.selfadjointView<Eigen::Lower>();
    TakeWindow(all, all_weight_, all, all_weight_);
  }
  SetPoint();
}

EstimatorDescriptor FrischDescriptor() {
  return {.name = "frisch",
          .help = "recursive Frisch scheme: a solution box and a point in it",
          .options = {"forgetting", "p0", "window", "frisch_box", "frisch_point", "frisch_confidence"},
          .traits = {.needs_noise_shape = true, .reports_box = true},
          .make = [](const EstimatorSettings& s, const Vec& theta0) -> std::unique_ptr<Estimator> {
            return std::make_unique<Frisch>(theta0, s.window, s.forgetting, s.PriorCovariance(theta0.size()), s.frisch_box,
                                            s.frisch_point, s.noise_shape, s.frisch_confidence);
          }};
}

}  // namespace hysid
