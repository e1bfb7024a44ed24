// The per-chain sums of the output-error fit and its compressed residual (sim/refine/chain_sums.hpp).
#include "sim/refine/chain_sums.hpp"

#include <algorithm>
#include <cmath>

#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace hysid {

Mat ChainSums::Information(const Vec& weight) const {
  Mat a = Mat::Zero(h.rows(), h.rows());
  for (std::size_t i = 0; i < gram.size(); ++i) a += weight[static_cast<Eigen::Index>(i)] * weight[static_cast<Eigen::Index>(i)] * gram[i];
  return a;
}

Vec ChainSums::Gradient(const Vec& weight) const { return -(h * weight.cwiseAbs2()); }

double ChainSums::Cost(const Vec& weight) const { return weight.cwiseAbs2().dot(squares); }

namespace {

// c_i and l_i of the residuals y − ξ_rows (the states x: n × K) into sums.
void ResidualSums(const Mat& x, const Eigen::Ref<const Mat>& y, const std::vector<int>& rows,
                  ChainSums& sums) {
  const Eigen::Index k_count = y.cols();
  const auto m = static_cast<Eigen::Index>(rows.size());
  sums.samples = k_count;
  sums.squares.resize(m);
  sums.lag.resize(m);
  for (Eigen::Index i = 0; i < m; ++i) {
    const Eigen::Index row = rows[static_cast<std::size_t>(i)];
    double squares = 0.0, lag = 0.0, previous = 0.0;
    for (Eigen::Index k = 0; k < k_count; ++k) {
      const double r = y(i, k) - x(row, k);
      squares += r * r;
      lag += previous * r;  // (0 for k = 0)
      previous = r;
    }
    sums.squares[i] = squares;
    sums.lag[i] = lag;
  }
}

}  // namespace

ChainSums SumChain(const SensitivityTrajectory& s, const Mat& y, const std::vector<int>& rows) {
  const Eigen::Index n = s.trajectory.x.rows(), p = s.parameters;
  const auto m = static_cast<Eigen::Index>(rows.size());
  ChainSums sums;
  ResidualSums(s.trajectory.x, y, rows, sums);
  sums.h.resize(p, m);
  std::vector<int> at(static_cast<std::size_t>(p));
  for (std::size_t i = 0; i < rows.size(); ++i) {
    // Row a·n + rows[i] of the sensitivities is ∂ξ_rows[i]/∂θ at every sample.
    for (Eigen::Index a = 0; a < p; ++a) at[static_cast<std::size_t>(a)] = static_cast<int>(a * n + rows[i]);
    const Mat rows_i = s.sensitivities(at, Eigen::all);  // p × K
    const Vec r = (y.row(static_cast<Eigen::Index>(i)) - s.trajectory.x.row(rows[i])).transpose();
    Mat g = Mat::Zero(p, p);
    g.selfadjointView<Eigen::Lower>().rankUpdate(rows_i);
    sums.gram.push_back(g.selfadjointView<Eigen::Lower>());
    sums.h.col(static_cast<Eigen::Index>(i)) = rows_i * r;
  }
  return sums;
}

ChainSummer::ChainSummer(const Eigen::Ref<const Mat>& y, const std::vector<int>& rows, int n, int p)
    : y_(y.data(), y.rows(), y.cols(), Eigen::OuterStride<>(y.outerStride())),
      rows_(rows),
      n_(n),
      gram_(rows.size(), Mat::Zero(p, p)),
      h_(Mat::Zero(p, static_cast<Eigen::Index>(rows.size()))),
      block_(rows.size(), Mat(kBlock, p)),
      residuals_(kBlock, static_cast<Eigen::Index>(rows.size())),
      last_(Mat::Zero(n, p)),
      window_residuals_(Mat::Zero(4, static_cast<Eigen::Index>(rows.size()))),
      ends_(4, p),
      ends_weighted_(4, p) {}

void ChainSummer::Sample(long k, const double* x, const double* s) {
  const Eigen::Index p = h_.rows();
  for (std::size_t i = 0; i < rows_.size(); ++i) {
    const int row = rows_[i];
    // S is column-major n × p: ∂ξ_row/∂θ_a is s[a·n + row].
    Mat& block = block_[i];
    for (Eigen::Index a = 0; a < p; ++a) block(gathered_, a) = s[a * n_ + row];
    residuals_(gathered_, static_cast<Eigen::Index>(i)) = y_(static_cast<Eigen::Index>(i), k) - x[row];
  }
  if (k + 1 == y_.cols()) last_ = Eigen::Map<const Mat>(s, n_, p);
  if (++gathered_ == kBlock) Flush();
}

void ChainSummer::WindowSample(long k, const double* x, const double* w) {
  const Eigen::Map<const Eigen::Vector4d> weights(w);
  window_weights_.noalias() += weights * weights.transpose();
  for (std::size_t i = 0; i < rows_.size(); ++i) {
    const double r = y_(static_cast<Eigen::Index>(i), k) - x[rows_[i]];
    window_residuals_.col(static_cast<Eigen::Index>(i)) += r * weights;
  }
  if (k + 1 == y_.cols()) {
    last_weights_ = weights;
    last_in_window_ = true;
  }
}

void ChainSummer::CloseWindow(const double* sa, const double* da, const double* sb, const double* db) {
  const Eigen::Index p = h_.rows();
  const double* ends[4] = {sa, da, sb, db};
  for (std::size_t i = 0; i < rows_.size(); ++i) {
    const int row = rows_[i];
    for (int e = 0; e < 4; ++e) {
      for (Eigen::Index a = 0; a < p; ++a) ends_(e, a) = ends[e][a * n_ + row];
    }
    ends_weighted_.noalias() = window_weights_ * ends_;
    gram_[i].noalias() += ends_.transpose() * ends_weighted_;
    h_.col(static_cast<Eigen::Index>(i)).noalias() +=
        ends_.transpose() * window_residuals_.col(static_cast<Eigen::Index>(i));
  }
  if (last_in_window_) {
    const auto size = static_cast<Eigen::Index>(n_) * p;
    Eigen::Map<Vec> last(last_.data(), size);
    last.setZero();
    for (int e = 0; e < 4; ++e) last += last_weights_[e] * Eigen::Map<const Vec>(ends[e], size);
    last_in_window_ = false;
  }
  window_weights_.setZero();
  window_residuals_.setZero();
}

// G_i's lower triangle and h_i as dot products of the block's columns (each unknown's sensitivities
// over the gathered samples, contiguous): for p of a few, Eigen's rank update spent most of its time
// packing blocks for its matrix kernel.
void ChainSummer::Flush() {
  const Eigen::Index p = h_.rows();
  for (std::size_t i = 0; i < rows_.size(); ++i) {
    const Mat& block = block_[i];
    Mat& gram = gram_[i];
    const auto r = residuals_.col(static_cast<Eigen::Index>(i)).head(gathered_);
    for (Eigen::Index a = 0; a < p; ++a) {
      const auto sa = block.col(a).head(gathered_);
      for (Eigen::Index b = 0; b <= a; ++b) gram(a, b) += sa.dot(block.col(b).head(gathered_));
      h_(a, static_cast<Eigen::Index>(i)) += sa.dot(r);
    }
  }
  gathered_ = 0;
}

ChainSums ChainSummer::Finish(const Mat& x) {
  Flush();
  ChainSums sums;
  ResidualSums(x, y_, rows_, sums);
  sums.h = h_;
  for (const Mat& g : gram_) sums.gram.push_back(g.selfadjointView<Eigen::Lower>());
  return sums;
}

ChainInformation ChainInformation::Of(const std::vector<Mat>& chains, int shared) {
  ChainInformation f;
  f.shared = Mat::Zero(shared, shared);
  for (const Mat& fc : chains) {
    const Eigen::Index n = fc.rows() - shared;
    f.shared += fc.topLeftCorner(shared, shared);
    f.coupling.push_back(fc.topRightCorner(shared, n));
    f.own.push_back(fc.bottomRightCorner(n, n));
  }
  return f;
}

Mat ChainInformation::Joint() const {
  const Eigen::Index s = shared.rows();
  Eigen::Index total = s;
  for (const Mat& d : own) total += d.rows();
  Mat f = Mat::Zero(total, total);
  f.topLeftCorner(s, s) = shared;
  Eigen::Index o = s;
  for (std::size_t c = 0; c < own.size(); ++c) {
    const Eigen::Index n = own[c].rows();
    f.block(0, o, s, n) = coupling[c];
    f.block(o, 0, n, s) = coupling[c].transpose();
    f.block(o, o, n, n) = own[c];
    o += n;
  }
  return f;
}

double ChainInformation::InverseQuadratic(const Vec& g) const {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const Eigen::Index s = shared.rows();
  Mat schur = shared;
  Vec reduced = g.head(s);
  double quadratic = 0.0;
  Eigen::Index o = s;
  for (std::size_t c = 0; c < own.size(); ++c) {
    const Eigen::Index n = own[c].rows();
    const Eigen::LLT<Mat> d(own[c]);
    if (d.info() != Eigen::Success) return kInf;
    const Vec gc = g.segment(o, n);
    const Vec dg = d.solve(gc);
    quadratic += gc.dot(dg);
    reduced -= coupling[c] * dg;
    schur -= coupling[c] * d.solve(coupling[c].transpose());
    o += n;
  }
  const Eigen::LLT<Mat> llt(schur);
  if (llt.info() != Eigen::Success) return kInf;
  quadratic += reduced.dot(llt.solve(reduced));
  return std::isfinite(quadratic) ? quadratic : kInf;
}

namespace {

// The LDLT of a symmetric block, positive definite with pivots above 1e-14 (CrlbFromFisher's test).
bool PositivePivots(const Eigen::LDLT<Mat>& ldlt) {
  return ldlt.info() == Eigen::Success && ldlt.isPositive() &&
         (ldlt.vectorD().size() == 0 || ldlt.vectorD().minCoeff() > 1e-14);
}

// diag(F)^(−1/2) of a block's diagonal; false when an entry is not positive and finite.
bool Equilibration(const Vec& diagonal, Vec* d) {
  if (!diagonal.allFinite() || !(diagonal.array() > 0.0).all()) return false;
  *d = diagonal.cwiseSqrt().cwiseInverse();
  return true;
}

}  // namespace

bool ChainInformation::CovarianceBlock(std::size_t c, Mat* covariance) const {
  const Eigen::Index s = shared.rows();
  Vec ds;
  if (!Equilibration(shared.diagonal(), &ds)) return false;
  Mat schur = ds.asDiagonal() * shared * ds.asDiagonal();  // of the equilibrated F
  Mat w_c;                                                 // D_c'⁻¹ B_c'ᵀ of chain c
  Mat own_c_inverse;
  Vec dc_kept;
  for (std::size_t k = 0; k < own.size(); ++k) {
    Vec dk;
    if (!Equilibration(own[k].diagonal(), &dk)) return false;
    const Mat b = ds.asDiagonal() * coupling[k] * dk.asDiagonal();
    const Eigen::LDLT<Mat> d(dk.asDiagonal() * own[k] * dk.asDiagonal());
    if (!PositivePivots(d)) return false;
    const Mat w = d.solve(b.transpose());
    schur -= b * w;
    if (k == c) {
      w_c = w;
      own_c_inverse = d.solve(Mat::Identity(dk.size(), dk.size()));
      dc_kept = dk;
    }
  }
  schur = 0.5 * (schur + schur.transpose()).eval();
  const Eigen::LDLT<Mat> ldlt(schur);
  if (!PositivePivots(ldlt)) return false;
  const Eigen::Index n = dc_kept.size();
  const Mat s_inverse = ldlt.solve(Mat::Identity(s, s));
  Mat e(s + n, s + n);  // the block of the equilibrated F⁻¹
  e.topLeftCorner(s, s) = s_inverse;
  e.topRightCorner(s, n) = -s_inverse * w_c.transpose();
  e.bottomLeftCorner(n, s) = e.topRightCorner(s, n).transpose();
  e.bottomRightCorner(n, n) = own_c_inverse + w_c * s_inverse * w_c.transpose();
  Vec d(s + n);
  d << ds, dc_kept;
  *covariance = d.asDiagonal() * e * d.asDiagonal();
  *covariance = 0.5 * (*covariance + covariance->transpose()).eval();
  return true;
}

void CompressedResidual(const ChainSums& sums, const Vec& weight, double* residuals, Mat* jacobian) {
  const Mat a = sums.Information(weight);
  const Vec g = sums.Gradient(weight);
  const auto p = a.rows();
  // Equilibrated, D·A·D = V Λ Vᵀ with D = diag(A)^(−1/2), so that unknowns in other units (a state
  // scaled by 1e6) do not push a direction below the rounding threshold: then R = Λ^(1/2) Vᵀ D⁻¹
  // and the residual Λ^(−1/2) Vᵀ D g.
  const Vec diag = a.diagonal();
  const Vec d = (diag.array() > 0.0).select(diag.cwiseSqrt().cwiseInverse(), Vec::Ones(p));
  const Eigen::SelfAdjointEigenSolver<Mat> eigen(d.asDiagonal() * a * d.asDiagonal());
  const Vec lambda = eigen.eigenvalues().cwiseMax(0.0);
  const Mat& v = eigen.eigenvectors();
  // Directions at rounding level carry no residual (g has no component there beyond rounding).
  const double tiny = lambda.size() > 0 ? lambda.maxCoeff() * 1e-14 * static_cast<double>(p) : 0.0;
  const Vec dg = d.cwiseProduct(g);
  Eigen::Map<Vec> res(residuals, p + 1);
  jacobian->setZero(p + 1, p);
  double explained = 0.0;
  for (Eigen::Index i = 0; i < p; ++i) {
    const double root = std::sqrt(lambda[i]);
    jacobian->row(i) = root * v.col(i).cwiseQuotient(d).transpose();
    res[i] = lambda[i] > tiny ? v.col(i).dot(dg) / root : 0.0;
    explained += res[i] * res[i];
  }
  res[p] = std::sqrt(std::max(0.0, sums.Cost(weight) - explained));
}

}  // namespace hysid
