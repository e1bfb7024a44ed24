// Residual tests at a stated size (sim/refine/residual_tests.hpp).
#include "sim/refine/residual_tests.hpp"

#include <algorithm>
#include <cmath>

#include "core/stats/quantiles.hpp"

namespace hysid {
namespace {

// The χ²_ν quantile at the standard normal quantile z (Wilson–Hilferty; within 0.1 % for ν ≥ 30).
double ChiSquareAt(double z, double nu) {
  const double a = 2.0 / (9.0 * nu);
  return nu * std::pow(std::max(0.0, 1.0 - a + z * std::sqrt(a)), 3.0);
}

}  // namespace

ResidualLimits ResidualLimitsFor(long N, double parameters, double alpha) {
  const double nu = std::max(1.0, static_cast<double>(N) - parameters);
  const double z = NormalUpperQuantile(alpha / 4.0);
  return {.level_low = ChiSquareAt(-z, nu), .level_high = ChiSquareAt(z, nu), .z = z};
}

ResidualTestResult ResidualTests(const std::vector<Mat>& residuals, const Vec& sigma, bool given, double parameters,
                                 double alpha) {
  ResidualTestResult t;
  const Eigen::Index m = sigma.size();
  double level = 0.0;
  long N = 0;
  const double z_crit = NormalUpperQuantile(alpha / (4.0 * static_cast<double>(m)));  // Bonferroni over rows
  for (Eigen::Index r = 0; r < m; ++r) {
    double sum2 = 0.0, lag = 0.0;
    long count = 0;
    for (const Mat& res : residuals) {
      for (Eigen::Index k = 0; k < res.cols(); ++k) {
        const double e = res(r, k);
        if (!std::isfinite(e)) continue;  // a sample left out
        sum2 += e * e;
        if (k > 0 && std::isfinite(res(r, k - 1))) lag += e * res(r, k - 1);
        ++count;
      }
    }
    level += sum2 / (sigma[r] * sigma[r]);
    N += count;
    const double rho = sum2 > 0.0 ? lag / sum2 : 0.0;
    const double z = std::sqrt(static_cast<double>(count)) * rho;
    if (std::abs(z) > std::abs(t.worst_z)) {
      t.worst_z = z;
      t.lag1 = rho;
    }
    t.white = t.white && std::abs(z) <= z_crit;
  }
  const double nu = std::max(1.0, static_cast<double>(N) - parameters);
  t.level_statistic = level / nu;
  if (given) {
    const ResidualLimits limits = ResidualLimitsFor(N, parameters, alpha);
    t.level_ok = level <= limits.level_high && level >= limits.level_low;
  }
  return t;
}

double SigmaOverMad(const Vec& sigma_hat, const Vec& mad_sigma, const Vec& floor) {
  double ratio = 0.0;
  for (Eigen::Index i = 0; i < sigma_hat.size(); ++i) {
    if (mad_sigma[i] > floor[i]) ratio = std::max(ratio, sigma_hat[i] / mad_sigma[i]);
  }
  return ratio;
}

Mat NeweyWestMeat(const std::vector<std::vector<Vec>>& scores, Eigen::Index P) {
  long N = 0;
  for (const auto& c : scores) N += static_cast<long>(c.size());
  const int L = static_cast<int>(std::floor(4.0 * std::pow(static_cast<double>(N) / 100.0, 2.0 / 9.0)));
  Mat meat = Mat::Zero(P, P);
  for (const auto& g : scores) {
    const auto K = static_cast<Eigen::Index>(g.size());
    // A chain's scores are zero outside θ and its own nodes: its terms are added on the rows where
    // they are not (the others add exact zeros), each in the same order as on the whole matrix.
    std::vector<Eigen::Index> rows;
    for (Eigen::Index i = 0; i < P; ++i) {
      if (std::any_of(g.begin(), g.end(), [i](const Vec& v) { return v[i] != 0.0; })) rows.push_back(i);
    }
    Mat G(static_cast<Eigen::Index>(rows.size()), K);
    for (Eigen::Index k = 0; k < K; ++k) G.col(k) = g[std::size_t(k)](rows);
    meat(rows, rows) += Mat(G * G.transpose());
    for (int l = 1; l <= L && l < K; ++l) {
      const Mat cross = G.rightCols(K - l) * G.leftCols(K - l).transpose();
      meat(rows, rows) += (1.0 - l / (L + 1.0)) * (cross + cross.transpose());
    }
  }
  return meat;
}

}  // namespace hysid
