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

ChainSums SumChain(const SensitivityTrajectory& s, const Mat& y, const std::vector<int>& rows) {
  const Eigen::Index n = s.trajectory.x.rows(), p = s.parameters, k_count = y.cols();
  const auto m = static_cast<Eigen::Index>(rows.size());
  ChainSums sums;
  sums.samples = k_count;
  sums.h.resize(p, m);
  sums.squares.resize(m);
  sums.lag.resize(m);
  std::vector<int> at(static_cast<std::size_t>(p));
  for (std::size_t i = 0; i < rows.size(); ++i) {
    // Row a·n + rows[i] of the sensitivities is ∂ξ_rows[i]/∂θ_a at every sample.
    for (Eigen::Index a = 0; a < p; ++a) at[static_cast<std::size_t>(a)] = static_cast<int>(a * n + rows[i]);
    const Mat rows_i = s.sensitivities(at, Eigen::all);  // p × K
    const Vec r = (y.row(static_cast<Eigen::Index>(i)) - s.trajectory.x.row(rows[i])).transpose();
    Mat g = Mat::Zero(p, p);
    g.selfadjointView<Eigen::Lower>().rankUpdate(rows_i);
    sums.gram.push_back(g.selfadjointView<Eigen::Lower>());
    const auto c = static_cast<Eigen::Index>(i);
    sums.h.col(c) = rows_i * r;
    sums.squares[c] = r.squaredNorm();
    sums.lag[c] = k_count > 1 ? r.head(k_count - 1).dot(r.tail(k_count - 1)) : 0.0;
  }
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
