#include "core/detectors/paper.hpp"

#include <cmath>
#include <stdexcept>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>

#include "core/sample_set.hpp"

namespace hysid {
namespace {

}  // namespace

// Squared spectral norm of a small matrix: the squared row norm for one row, else λmax(AAᵀ).
[[gnu::noinline]] double SpectralNormSquared(const Eigen::Ref<const Mat>& a) {
  if (a.rows() == 1) return a.row(0).squaredNorm();
  const Mat g = a.rows() <= a.cols() ? Mat(a * a.transpose()) : Mat(a.transpose() * a);
  const Eigen::SelfAdjointEigenSolver<Mat> eig(g, Eigen::EigenvaluesOnly);
  return std::max(0.0, eig.eigenvalues().maxCoeff());
}

BoundMode ResolveBoundMode(const std::string& bound, const Model& model) {
  if (bound == "paper") return BoundMode::kPaper;
  if (bound == "homogeneous") return BoundMode::kHomogeneous;
  if (bound != "auto") {
    throw std::invalid_argument(fmt::format(
        "detector bound = '{}': must be one of auto, paper, homogeneous", bound));
  }
  const int n = model.state_size();
  Mat phi(n, model.alpha_size());
  model.Phi(Vec::Zero(n), phi);
  for (int r : model.spec().flow_rows) {
    if (phi.row(r).any()) return BoundMode::kHomogeneous;
  }
  return BoundMode::kPaper;
}

double BoundNorm(ConstVecRef x, BoundMode mode) {
  const double s = x.squaredNorm();
  return std::sqrt(mode == BoundMode::kHomogeneous ? s + 1.0 : s);
}

double SupJacobianNorm(const Model& model, ConstVecRef alpha, BoundMode mode,
                       const Eigen::Ref<const Mat>& points) {
  const int n = model.state_size();
  const auto& rows = model.spec().flow_rows;
  const int nr = static_cast<int>(rows.size());
  Mat jac(n, n), reduced(nr, mode == BoundMode::kHomogeneous ? n + 1 : n);
  Vec f0(n);
  if (mode == BoundMode::kHomogeneous) {
    const Vec zero = Vec::Zero(n);
    model.Flow(zero, alpha, f0);
  }
  const Eigen::Index count = model.spec().flow_jacobian_constant ? 1 : points.cols();
  double sup = 0.0;
  for (Eigen::Index k = 0; k < count; ++k) {
    model.FlowJacobian(points.col(k), alpha, jac);
    for (int i = 0; i < nr; ++i) {
      reduced.row(i).head(n) = jac.row(rows[static_cast<std::size_t>(i)]);
      if (mode == BoundMode::kHomogeneous) reduced(i, n) = f0[rows[static_cast<std::size_t>(i)]];
    }
    sup = std::max(sup, std::sqrt(SpectralNormSquared(reduced)));
  }
  return sup;
}

PaperDetector::PaperDetector(const DetectorSettings& settings, const Model& model)
    : r_(settings.r),
      tau0_(settings.tau0),
      mode_(ResolveBoundMode(settings.bound, model)),
      constant_jacobian_(model.spec().flow_jacobian_constant) {
  int unknowns = 0;
  for (const Parameter& p : model.spec().alpha) unknowns += p.known ? 0 : 1;
  unknowns_ = unknowns;
  if (constant_jacobian_) {
    const int n = model.state_size(), p = model.alpha_size();
    const auto& rows = model.spec().flow_rows;
    reduced_rows_ = static_cast<int>(rows.size());
    const int cols = mode_ == BoundMode::kHomogeneous ? n + 1 : n;
    g_.resize(reduced_rows_ * cols, p);
    Mat jac(n, n);
    Vec f0(n);
    const Vec zero = Vec::Zero(n);
    for (int i = 0; i < p; ++i) {
      const Vec unit = Vec::Unit(p, i);
      model.FlowJacobian(zero, unit, jac);
      model.Flow(zero, unit, f0);
      for (int r = 0; r < reduced_rows_; ++r) {
        const int row = rows[static_cast<std::size_t>(r)];
        for (int c = 0; c < n; ++c) g_(c * reduced_rows_ + r, i) = jac(row, c);
        if (mode_ == BoundMode::kHomogeneous) g_(n * reduced_rows_ + r, i) = f0[row];
      }
    }
    jvec_.resize(g_.rows());
  }
}

// ‖J̄_r(α)‖₂² for a constant Jacobian: one identified row is a squared vector norm.
double PaperDetector::LinearNormSquared(ConstVecRef alpha) {
  const Eigen::Index m = g_.rows(), p = g_.cols();
  const double* g = g_.data();
  double* j = jvec_.data();
  for (Eigen::Index r = 0; r < m; ++r) j[r] = 0.0;
  for (Eigen::Index c = 0; c < p; ++c) {
    const double a = alpha[c];
    for (Eigen::Index r = 0; r < m; ++r) j[r] += g[c * m + r] * a;
  }
  if (reduced_rows_ == 1) {
    double s = 0.0;
    for (Eigen::Index r = 0; r < m; ++r) s += j[r] * j[r];
    return s;
  }
  return SpectralNormSquared(Eigen::Map<const Mat>(j, reduced_rows_, m / reduced_rows_));
}

void PaperDetector::Reset() {
  cached_version_ = -1;
  cached_hull_version_ = -1;
  cached_l2_ = 0.0;
}

// The decision is taken on squares, D² > τ̂², so that no square root sits on the chain
// α̂ → τ̂ → γ → α̂ of consecutive samples; D and τ̂ themselves are computed off that chain.
Decision PaperDetector::Classify(const SampleContext& c) {
  Decision d;
  const double inv_dt = 1.0 / c.dt;
  double d2 = 0.0;
  for (Eigen::Index i = 0; i < c.cur.size(); ++i) {
    const double v = (c.cur[i] - c.prev[i]) * inv_dt;
    d2 += v * v;
  }
  d.statistic = std::sqrt(d2);
  if (c.flow_updates < unknowns_) {
    d.threshold = tau0_;
    d.gamma = d.statistic > d.threshold;
    return d;
  }
  double l2 = 0.0;
  if (constant_jacobian_) {
    if (c.version != cached_version_) {
      cached_l2_ = LinearNormSquared(c.alpha_hat);
      cached_version_ = c.version;
    }
    l2 = cached_l2_;
  } else {
    // Vertices of Ĉ (cached per α̂ and hull version), then the current pair.
    const long hull_version = c.flow_set ? c.flow_set->version() : -1;
    if (c.version != cached_version_ || hull_version != cached_hull_version_) {
      double l = 0.0;
      if (c.flow_set && c.flow_set->hull_dimension() >= 0) {
        points_ = c.flow_set->vertices();
        l = SupJacobianNorm(*c.model, c.alpha_hat, mode_, points_);
      }
      cached_l2_ = l * l;
      cached_version_ = c.version;
      cached_hull_version_ = hull_version;
    }
    Mat pair(c.cur.size(), 2);
    pair.col(0) = c.prev;
    pair.col(1) = c.cur;
    const double l = SupJacobianNorm(*c.model, c.alpha_hat, mode_, pair);
    l2 = std::max(cached_l2_, l * l);
  }
  const double s = BoundNorm(c.cur, mode_) + BoundNorm(c.prev, mode_);
  const double half_r = 0.5 * r_;
  d.gamma = d2 > half_r * half_r * l2 * s * s;
  d.threshold = half_r * std::sqrt(l2) * s;
  return d;
}

}  // namespace hysid
