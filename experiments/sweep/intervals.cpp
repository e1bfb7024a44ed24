#include "experiments/sweep/intervals.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "core/stats/quantiles.hpp"

namespace hysid {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct MeanAndStd {
  double mean = 0, std = 0;
};

MeanAndStd MomentsOf(const std::vector<double>& v) {
  MeanAndStd m;
  for (double x : v) m.mean += x;
  m.mean /= static_cast<double>(v.size());
  double ss = 0;
  for (double x : v) ss += (x - m.mean) * (x - m.mean);
  m.std = std::sqrt(ss / static_cast<double>(v.size() - 1));
  return m;
}

// The q-quantile of sorted values, linearly interpolated between order statistics (position q·(B − 1)).
double SortedQuantile(const std::vector<double>& sorted, double q) {
  const double pos = q * static_cast<double>(sorted.size() - 1);
  const auto i = static_cast<std::size_t>(pos);
  if (i + 1 >= sorted.size()) return sorted.back();
  const double f = pos - static_cast<double>(i);
  return sorted[i] + f * (sorted[i + 1] - sorted[i]);
}

}  // namespace

std::array<double, 2> WilsonInterval(double p, double n, double z) {
  const double z2n = z * z / n;
  const double centre = (p + 0.5 * z2n) / (1.0 + z2n);
  const double half = z * std::sqrt(p * (1.0 - p) / n + 0.25 * z2n / n) / (1.0 + z2n);
  return {std::max(0.0, centre - half), std::min(1.0, centre + half)};
}

std::array<double, 2> RateInterval(const std::vector<double>& values) {
  if (values.size() < 2) return {kNaN, kNaN};
  const MeanAndStd m = MomentsOf(values);
  const double p = std::clamp(m.mean, 0.0, 1.0);
  const double n = static_cast<double>(values.size());
  const double var_of_mean = m.std * m.std / n;
  if (var_of_mean <= 0 || p <= 0 || p >= 1) return {m.mean, m.mean};
  const double z = StudentUpperQuantile(0.025, n - 1.0);
  return WilsonInterval(p, p * (1.0 - p) / var_of_mean, z);
}

std::array<double, 2> BootstrapMeanInterval(const std::vector<double>& values) {
  if (values.size() < 2) return {kNaN, kNaN};
  if (std::all_of(values.begin(), values.end(), [&](double x) { return x == values[0]; }))
    return {values[0], values[0]};
  std::mt19937_64 rng(kBootstrapSeed);
  const std::uint64_t n = values.size();
  std::vector<double> means(kBootstrapResamples);
  for (double& mean : means) {
    double sum = 0;
    // rng() % n: the modulo bias is below n / 2⁶⁴, far under the interval's Monte Carlo error.
    for (std::uint64_t k = 0; k < n; ++k) sum += values[static_cast<std::size_t>(rng() % n)];
    mean = sum / static_cast<double>(n);
  }
  std::sort(means.begin(), means.end());
  return {SortedQuantile(means, 0.025), SortedQuantile(means, 0.975)};
}

}  // namespace hysid
