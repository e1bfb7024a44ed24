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

}  // namespace hysid
