#include "core/estimators/gtls.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <fmt/format.h>

namespace hysid {

namespace {

constexpr double kRankTolerance = 1e-10;  // smallest admissible Cholesky pivot² of D S_φφ D
constexpr double kRidge = 1e-13;          // added to the equilibrated S at refactorisation
constexpr double kGenericTolerance = 1e-8;
// Smallest admissible SupportGap: the weakest regressor direction carries at least the noise's energy,
// and stands above it by at least 10 sampling standard deviations of the noise eigenvalue (√(2/W)).
constexpr double kMinSupport = 1.0;
constexpr double kMinSupportSd = 10.0;

Mat CheckedShape(const Mat& shape, Eigen::Index m) {
  if (shape.size() == 0) return Mat::Identity(m, m);
  if (shape.rows() != m || shape.cols() != m) {
    throw std::invalid_argument(fmt::format("gtls: noise_shape is {}x{}, expected {}x{} (parameters + 1)",
                                            shape.rows(), shape.cols(), m, m));
  }
  if (!shape.allFinite()) throw std::invalid_argument("gtls: noise_shape must be finite");
  const double asym = (shape - shape.transpose()).cwiseAbs().maxCoeff();
  const double size = shape.cwiseAbs().maxCoeff();
  if (!(size > 0.0)) throw std::invalid_argument("gtls: noise_shape must not be zero");
  if (asym > 1e-12 * size) {
    throw std::invalid_argument(fmt::format("gtls: noise_shape is not symmetric (max |C - C^T| = {})", asym));
  }
  const Mat sym = 0.5 * (shape + shape.transpose());
  const double min_eig =
      Eigen::SelfAdjointEigenSolver<Mat>(sym, Eigen::EigenvaluesOnly).eigenvalues().minCoeff();
  if (min_eig < -1e-12 * size) {
    throw std::invalid_argument(
        fmt::format("gtls: noise_shape must be positive semidefinite (smallest eigenvalue {})", min_eig));
  }
  return sym;
}

}  // namespace

Gtls::Gtls(const Vec& theta0, const Mat& noise_shape, double forgetting, int refactor_every)
    : Estimator(theta0),
      c_(CheckedShape(noise_shape, theta0.size() + 1)),
      lambda_(forgetting),
      refactor_every_(refactor_every) {
  if (!(forgetting > 0.0 && forgetting <= 1.0)) {
    throw std::invalid_argument(fmt::format("gtls: forgetting = {}: must be in (0, 1]", forgetting));
  }
  if (refactor_every < 1) {
    throw std::invalid_argument(fmt::format("gtls: refactor_every = {}: must be >= 1", refactor_every));
  }
  Reset();
}

void Gtls::Reset() {
  ResetToPrior();
  const Eigen::Index m = theta0_.size() + 1;
  s_ = Mat::Zero(m, m);
  p_ = Mat::Zero(m, m);
  v_ = Vec::Zero(m);
  v_[m - 1] = -1.0;
  v_.head(m - 1) = theta0_;
  scale_ = Vec::Ones(m);
  z_.resize(m);
  g_.resize(m);
  t_.resize(m);
  weight_ = 0.0;
  support_ = 0.0;
  rows_ = 0;
  rows_since_refactor_ = 0;
  started_ = false;
  needs_refactor_ = false;
}

double Gtls::noise_variance() const {
  if (!started_ || !(weight_ > 0.0)) return 0.0;
  const double den = v_.dot(c_ * v_);
  if (!(den > 0.0)) return 0.0;
  return v_.dot(s_ * v_) / den / weight_;
}

void Gtls::Refresh() {
  if (started_) Factorize();
}

bool Gtls::Factorize() {
  const Eigen::Index m = s_.rows();
  const Eigen::Index p = m - 1;
  rows_since_refactor_ = 0;
  s_ = 0.5 * (s_ + s_.transpose()).eval();
  const double max_diag = s_.diagonal().maxCoeff();
  if (!(max_diag > 0.0) || !std::isfinite(max_diag)) {
    status_ = EstimatorStatus::kNotExcited;
    needs_refactor_ = true;
    return false;
  }
  // Column equilibration; a (numerically) zero column keeps scale 1 and fails the rank check
  // below when it is a regressor.
  for (Eigen::Index i = 0; i < m; ++i) {
    const double d = s_(i, i);
    scale_[i] = d > 1e-28 * max_diag ? 1.0 / std::sqrt(d) : 1.0;
  }
  Mat sd = scale_.asDiagonal() * s_ * scale_.asDiagonal();
  // Rank of the regressor block: no excitation, repeated rows, collinear or zero columns.
  const Eigen::LLT<Mat> block(sd.topLeftCorner(p, p));
  bool excited = block.info() == Eigen::Success;
  if (excited) {
    const Mat l = block.matrixL();
    for (Eigen::Index i = 0; i < p; ++i) excited = excited && l(i, i) * l(i, i) >= kRankTolerance;
  }
  if (!excited) {
    status_ = EstimatorStatus::kNotExcited;
    needs_refactor_ = true;
    return false;
  }
  sd.diagonal().array() += kRidge;
  const Eigen::LLT<Mat> llt(sd);
  if (llt.info() != Eigen::Success) {
    SetNotOk(EstimatorStatus::kIllConditioned, "the information matrix [phi y]'[phi y] is not positive definite");
    needs_refactor_ = true;
    return false;
  }
  const Mat l = llt.matrixL();
  const Mat pd = llt.solve(Mat::Identity(m, m));
  p_ = scale_.asDiagonal() * pd * scale_.asDiagonal();
  p_ = 0.5 * (p_ + p_.transpose()).eval();
  // M = L⁻¹ (DCD) L⁻ᵀ, symmetric PSD; its top eigenvector u gives v = D L⁻ᵀ u.
  const Mat cd = scale_.asDiagonal() * c_ * scale_.asDiagonal();
  const Mat half = l.triangularView<Eigen::Lower>().solve(cd);                    // L⁻¹ C_d
  Mat mm = l.triangularView<Eigen::Lower>().solve(half.transpose()).transpose();  // L⁻¹ C_d L⁻ᵀ
  mm = 0.5 * (mm + mm.transpose()).eval();
  const Eigen::SelfAdjointEigenSolver<Mat> eig(mm);
  if (eig.info() != Eigen::Success || !(eig.eigenvalues()[m - 1] > 0.0)) {
    SetNotOk(EstimatorStatus::kIllConditioned, "the generalized eigenproblem C v = nu S v failed");
    needs_refactor_ = true;
    return false;
  }
  support_ = SupportGap(l, cd, eig.eigenvalues()[m - 1]);
  const Vec u = eig.eigenvectors().col(m - 1);
  const Vec vd = l.transpose().triangularView<Eigen::Upper>().solve(u);
  v_ = scale_.asDiagonal() * vd;
  v_ /= v_.norm();
  needs_refactor_ = false;
  SetThetaFromEigenvector();
  return true;
}

double Gtls::SupportGap(const Mat& l, const Mat& cd, double mu_top) const {
  const Eigen::Index p = l.rows() - 1;
  const Mat lp = l.topLeftCorner(p, p);
  const Mat half = lp.triangularView<Eigen::Lower>().solve(cd.topLeftCorner(p, p));
  Mat mp = lp.triangularView<Eigen::Lower>().solve(half.transpose()).transpose();
  mp = 0.5 * (mp + mp.transpose()).eval();
  const double mu_block =
      Eigen::SelfAdjointEigenSolver<Mat>(mp, Eigen::EigenvaluesOnly).eigenvalues()[p - 1];
  if (!(mu_block > 0.0)) return std::numeric_limits<double>::infinity();
  return mu_top / mu_block - 1.0;
}

bool Gtls::FactorThetaBlock(Vec* d, Eigen::LLT<Mat>* llt) const {
  const Eigen::Index p = theta_.size();
  if (rows_ < p) return false;
  d->resize(p);
  for (Eigen::Index i = 0; i < p; ++i) {
    if (!(s_(i, i) > 0.0) || !std::isfinite(s_(i, i))) return false;
    (*d)[i] = 1.0 / std::sqrt(s_(i, i));
  }
  llt->compute(d->asDiagonal() * s_.topLeftCorner(p, p) * d->asDiagonal());
  if (llt->info() != Eigen::Success) return false;
  const Mat& l = llt->matrixLLT();
  for (Eigen::Index i = 0; i < p; ++i) {
    if (!(l(i, i) * l(i, i) >= kRankTolerance)) return false;
  }
  return true;
}

const Mat* Gtls::covariance_matrix() const {
  if (cov_updates_ != updates_ || updates_ == 0) {
    cov_updates_ = -2;
    Vec d;
    Eigen::LLT<Mat> llt;
    if (!FactorThetaBlock(&d, &llt)) return nullptr;
    const Eigen::Index p = theta_.size();
    cov_ = d.asDiagonal() * llt.solve(Mat::Identity(p, p)) * d.asDiagonal();
    cov_updates_ = updates_;
  }
  return cov_updates_ == -2 ? nullptr : &cov_;
}

void Gtls::ProvisionalLeastSquares() {
  const Eigen::Index p = theta_.size();
  Vec d;
  Eigen::LLT<Mat> llt;
  if (!FactorThetaBlock(&d, &llt)) return;
  const Vec theta = d.asDiagonal() * llt.solve(d.asDiagonal() * s_.col(p).head(p));
  if (theta.allFinite()) theta_ = theta;
}

void Gtls::SetThetaFromEigenvector() {
  const Eigen::Index m = v_.size();
  // Genericity in equilibrated coordinates v_d = D⁻¹ v.
  double norm2 = 0.0;
  for (Eigen::Index i = 0; i < m; ++i) {
    const double vd = v_[i] / scale_[i];
    norm2 += vd * vd;
  }
  const double last = v_[m - 1] / scale_[m - 1];
  if (!std::isfinite(norm2) || !(std::abs(last) > kGenericTolerance * std::sqrt(norm2))) {
    status_ = EstimatorStatus::kNonGeneric;
    return;
  }
  const double inv = -1.0 / v_[m - 1];
  for (Eigen::Index i = 0; i + 1 < m; ++i) theta_[i] = v_[i] * inv;
  const double needed = std::max(kMinSupport, kMinSupportSd * std::sqrt(2.0 / weight_));
  if (!(support_ >= needed)) {
    SetNotOk(EstimatorStatus::kIllConditioned,
             fmt::format("the regressors' weakest direction is within the noise: its signal-to-noise energy "
                         "ratio is {:.3g}, needs {:.3g}; the errors-in-variables correction is not determined "
                         "by the data",
                         support_, needed));
    return;
  }
  status_ = EstimatorStatus::kOk;
  reason_.clear();
}

// Forgetting: S ← λS, P ← P/λ and the weight ← λ·weight, unless every row of the block is zero.
void Gtls::Forget(const ConstMatRef& phi, const ConstVecRef& y) {
  bool any = false;
  for (Eigen::Index r = 0; r < phi.rows() && !any; ++r) any = phi.row(r).any() || y[r] != 0.0;
  if (!any || lambda_ == 1.0) return;
  const Eigen::Index m = phi.cols() + 1;
  double* s = s_.data();
  double* pp = p_.data();
  const double inv = 1.0 / lambda_;
  for (Eigen::Index i = 0; i < m * m; ++i) {
    s[i] *= lambda_;
    pp[i] *= inv;
  }
  weight_ *= lambda_;
}

// S += z zᵀ for the row z = [φ_r, y_r] held in z_; once started, P = S⁻¹ follows by Sherman–Morrison
// (a non-positive or non-finite denominator asks for a refactorization instead).
void Gtls::AddRow(Eigen::Index m) {
  double* s = s_.data();
  double* pp = p_.data();
  const double* z = z_.data();
  double* g = g_.data();
  for (Eigen::Index c = 0; c < m; ++c) {
    for (Eigen::Index i = 0; i < m; ++i) s[c * m + i] += z[i] * z[c];
  }
  weight_ += 1.0;
  ++rows_;
  ++rows_since_refactor_;
  if (!started_ || needs_refactor_) return;
  double den = 1.0;
  for (Eigen::Index i = 0; i < m; ++i) {
    double acc = 0.0;
    for (Eigen::Index k = 0; k < m; ++k) acc += pp[k * m + i] * z[k];
    g[i] = acc;
    den += z[i] * acc;
  }
  if (!(den > 0.0) || !std::isfinite(den)) {
    needs_refactor_ = true;
    return;
  }
  const double inv = 1.0 / den;
  for (Eigen::Index c = 0; c < m; ++c) {
    for (Eigen::Index i = c; i < m; ++i) {
      const double val = pp[c * m + i] - g[i] * g[c] * inv;
      pp[c * m + i] = val;
      pp[i * m + c] = val;
    }
  }
}

// One sweep of inverse iteration: v ← P C v / ‖·‖, then θ from v.
void Gtls::InverseIterationStep(Eigen::Index m) {
  const double* cc = c_.data();
  const double* pp = p_.data();
  double* t = t_.data();
  double* v = v_.data();
  double* g = g_.data();
  for (Eigen::Index i = 0; i < m; ++i) {
    double acc = 0.0;
    for (Eigen::Index k = 0; k < m; ++k) acc += cc[k * m + i] * v[k];
    t[i] = acc;
  }
  double norm2 = 0.0;
  for (Eigen::Index i = 0; i < m; ++i) {
    double acc = 0.0;
    for (Eigen::Index k = 0; k < m; ++k) acc += pp[k * m + i] * t[k];
    g[i] = acc;
    norm2 += acc * acc;
  }
  if (!(norm2 > 0.0) || !std::isfinite(norm2)) {
    needs_refactor_ = true;
    SetNotOk(EstimatorStatus::kIllConditioned, "inverse iteration lost the eigenvector");
    return;
  }
  const double inv = 1.0 / std::sqrt(norm2);
  for (Eigen::Index i = 0; i < m; ++i) v[i] = g[i] * inv;
  SetThetaFromEigenvector();
}

void Gtls::DoUpdate(const ConstMatRef& phi, const ConstVecRef& y) {
  const Eigen::Index p = phi.cols();
  const Eigen::Index m = p + 1;
  Forget(phi, y);
  double* z = z_.data();
  for (Eigen::Index r = 0; r < phi.rows(); ++r) {
    for (Eigen::Index i = 0; i < p; ++i) z[i] = phi(r, i);
    z[p] = y[r];
    AddRow(m);
  }
  if (!started_) {
    if (rows_ >= 2 * m && Factorize()) {
      started_ = true;
    } else {
      ProvisionalLeastSquares();
    }
    return;
  }
  if (needs_refactor_ || rows_since_refactor_ >= refactor_every_) {
    Factorize();
    return;
  }
  InverseIterationStep(m);
}

EstimatorDescriptor GtlsDescriptor() {
  return {.name = "gtls",
          .help = "recursive generalized total least squares (noise shape C from sigma and dt)",
          .options = {"forgetting", "refactor_every"},
          .traits = {.needs_noise_shape = true},
          .make = [](const EstimatorSettings& s, const Vec& theta0) -> std::unique_ptr<Estimator> {
            return std::make_unique<Gtls>(theta0, s.noise_shape, s.forgetting, s.refactor_every);
          }};
}

}  // namespace hysid
