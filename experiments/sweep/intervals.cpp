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

// The q-quantile of the values, linearly interpolated between order statistics (position q·(B − 1));
// the order statistics come from nth_element and the minimum above it, the same values as a sort.
// Reorders the values.
double OrderQuantile(std::vector<double>* values, double q) {
  std::vector<double>& v = *values;
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto i = static_cast<std::size_t>(pos);
  const auto at = v.begin() + static_cast<std::ptrdiff_t>(i);
  std::nth_element(v.begin(), at, v.end());
  if (i + 1 >= v.size()) return *at;
  const double next = *std::min_element(at + 1, v.end());
  const double f = pos - static_cast<double>(i);
  return *at + f * (next - *at);
}

// The percentile interval from the resample means.
std::array<double, 2> PercentileBounds(std::vector<double>* means) {
  const double lo = OrderQuantile(means, 0.025);
  return {lo, OrderQuantile(means, 0.975)};
}

// {NaN, NaN} for fewer than 2 values, {v, v} when all equal v: true with *out set.
bool DegenerateInterval(const std::vector<double>& values, std::array<double, 2>* out) {
  if (values.size() < 2) {
    *out = {kNaN, kNaN};
    return true;
  }
  if (!std::all_of(values.begin(), values.end(), [&](double x) { return x == values[0]; })) return false;
  *out = {values[0], values[0]};
  return true;
}

// Resamples summed side by side by a plan: independent chains of additions, each in draw order.
constexpr std::size_t kLanes = 4;
static_assert(kBootstrapResamples % kLanes == 0);

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
  std::array<double, 2> degenerate;
  if (DegenerateInterval(values, &degenerate)) return degenerate;
  std::mt19937_64 rng(kBootstrapSeed);
  const std::uint64_t n = values.size();
  std::vector<double> means(kBootstrapResamples);
  for (double& mean : means) {
    double sum = 0;
    // rng() % n: the modulo bias is below n / 2⁶⁴, far under the interval's Monte Carlo error.
    for (std::uint64_t k = 0; k < n; ++k) sum += values[static_cast<std::size_t>(rng() % n)];
    mean = sum / static_cast<double>(n);
  }
  return PercentileBounds(&means);
}

// The draws of BootstrapMeanInterval in its order, stored lane-interleaved: draw k of resample b at
// (b / kLanes)·kLanes·n + kLanes·k + b % kLanes, so MeanInterval reads them in sequence.
BootstrapPlan::BootstrapPlan(std::size_t n) : n_(n), index_(kBootstrapResamples * n) {
  std::mt19937_64 rng(kBootstrapSeed);
  for (std::size_t b = 0; b < kBootstrapResamples; ++b) {
    std::uint32_t* block = index_.data() + (b / kLanes) * kLanes * n + b % kLanes;
    for (std::size_t k = 0; k < n; ++k) block[kLanes * k] = static_cast<std::uint32_t>(rng() % n);
  }
}

std::array<double, 2> BootstrapPlan::MeanInterval(const std::vector<double>& values) const {
  std::array<double, 2> degenerate;
  if (DegenerateInterval(values, &degenerate)) return degenerate;
  const double* v = values.data();
  std::vector<double> means(kBootstrapResamples);
  for (std::size_t b = 0; b < kBootstrapResamples; b += kLanes) {
    const std::uint32_t* block = index_.data() + b * n_;
    std::array<double, kLanes> sum{};
    for (std::size_t k = 0; k < n_; ++k) {
      for (std::size_t l = 0; l < kLanes; ++l) sum[l] += v[block[kLanes * k + l]];
    }
    for (std::size_t l = 0; l < kLanes; ++l) means[b + l] = sum[l] / static_cast<double>(n_);
  }
  return PercentileBounds(&means);
}

const BootstrapPlan* BootstrapPlans::PlanFor(std::size_t n) {
  const std::lock_guard<std::mutex> lock(mutex_);
  auto& plan = plans_[n];
  if (plan == nullptr && indices_ + kBootstrapResamples * n <= kMaxPlanIndices) {
    plan = std::make_unique<const BootstrapPlan>(n);
    indices_ += kBootstrapResamples * n;
  }
  return plan.get();
}

std::array<double, 2> BootstrapPlans::MeanInterval(const std::vector<double>& values) {
  std::array<double, 2> degenerate;
  if (DegenerateInterval(values, &degenerate)) return degenerate;
  const BootstrapPlan* plan = PlanFor(values.size());
  return plan != nullptr ? plan->MeanInterval(values) : BootstrapMeanInterval(values);
}

}  // namespace hysid
