// The per-chain sums of the output-error fit and its compressed residual (sim/refine/chain_sums.hpp).
#include "sim/refine/chain_sums.hpp"

#include <algorithm>
#include <cmath>

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
      block_(rows.size(), Mat(p, kBlock)),
      residuals_(kBlock, static_cast<Eigen::Index>(rows.size())),
      last_(Mat::Zero(n, p)) {}

void ChainSummer::Sample(long k, const double* x, const double* s) {
  const Eigen::Index p = h_.rows();
  for (std::size_t i = 0; i < rows_.size(); ++i) {
    const int row = rows_[i];
    // S is column-major n × p: ∂ξ_row/∂θ_a is s[a·n + row].
    double* column = block_[i].col(gathered_).data();
    for (Eigen::Index a = 0; a < p; ++a) column[a] = s[a * n_ + row];
    residuals_(gathered_, static_cast<Eigen::Index>(i)) = y_(static_cast<Eigen::Index>(i), k) - x[row];
  }
  if (k + 1 == y_.cols()) last_ = Eigen::Map<const Mat>(s, n_, p);
  if (++gathered_ == kBlock) Flush();
}

void ChainSummer::Flush() {
  for (std::size_t i = 0; i < rows_.size(); ++i) {
    const auto rows = block_[i].leftCols(gathered_);
    gram_[i].selfadjointView<Eigen::Lower>().rankUpdate(rows);
    h_.col(static_cast<Eigen::Index>(i)).noalias() +=
        rows * residuals_.col(static_cast<Eigen::Index>(i)).head(gathered_);
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
