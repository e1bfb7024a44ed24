// The range-respecting intervals of summary.csv: the Wilson interval against its closed form and
// published values, the rate interval's effective sample size for 0/1 data, the percentile bootstrap
// against the exact binomial quantiles of resampled 0/1 data, and both staying inside the range.
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <catch2/catch.hpp>

#include "core/stats/quantiles.hpp"
#include "experiments/sweep/intervals.hpp"
#include "experiments/sweep/tables.hpp"

using namespace hysid;

namespace {

// k ones and n − k zeros.
std::vector<double> ZerosAndOnes(int n, int k) {
  std::vector<double> v(static_cast<std::size_t>(n), 0.0);
  for (int i = 0; i < k; ++i) v[static_cast<std::size_t>(i * n / k)] = 1.0;
  return v;
}

}  // namespace

TEST_CASE("Wilson interval: closed form and published values", "[intervals]") {
  // 0 of 10 at z = 1.96: [0, z²/(n + z²)].
  const auto zero = WilsonInterval(0.0, 10.0, 1.96);
  CHECK(zero[0] == 0.0);
  CHECK(zero[1] == Approx(1.96 * 1.96 / (10.0 + 1.96 * 1.96)).epsilon(1e-12));
  // 4 of 20 (Newcombe 1998, Table I style): [0.0807, 0.4160].
  const auto w = WilsonInterval(0.2, 20.0, 1.96);
  CHECK(w[0] == Approx(0.08066).margin(5e-5));
  CHECK(w[1] == Approx(0.41602).margin(5e-5));
  // Its bounds p0 solve (p − p0)² = z²·p0(1 − p0)/n.
  for (double p0 : w) CHECK((0.2 - p0) * (0.2 - p0) == Approx(1.96 * 1.96 * p0 * (1 - p0) / 20.0).epsilon(1e-10));
}

TEST_CASE("rate interval: 0/1 data give the Wilson interval with n − 1 trials and t(0.975, n − 1)", "[intervals]") {
  const std::vector<double> v = ZerosAndOnes(40, 6);
  const auto r = RateInterval(v);
  const auto w = WilsonInterval(6.0 / 40.0, 39.0, StudentUpperQuantile(0.025, 39.0));
  CHECK(r[0] == Approx(w[0]).epsilon(1e-12));
  CHECK(r[1] == Approx(w[1]).epsilon(1e-12));
  // Tiny rates (a few misclassified samples in one trial of many) keep a lower bound ≥ 0, unlike the
  // t-interval, and contain the mean.
  std::vector<double> rare(100, 0.0);
  rare[17] = 1e-4;
  const auto t = Summarize(rare);
  CHECK(t.ci_lo < 0.0);
  const auto q = RateInterval(rare);
  CHECK(q[0] >= 0.0);
  CHECK(q[0] <= 1e-6);
  CHECK(q[1] >= 1e-6);
  // Degenerate cells: all equal → the point; fewer than 2 values → none.
  CHECK(RateInterval({0.0, 0.0, 0.0}) == std::array<double, 2>{0.0, 0.0});
  CHECK(std::isnan(RateInterval({0.5})[0]));
}

TEST_CASE("bootstrap interval: exact binomial quantiles of resampled 0/1 data", "[intervals]") {
  // A resample's mean of 4 ones among 25 is Binomial(25, 4/25)/25: its 2.5 % and 97.5 % quantiles are
  // 1/25 and 8/25 (P(X ≤ 0) = 0.013, P(X ≤ 1) = 0.074; P(X ≤ 7) = 0.964, P(X ≤ 8) = 0.988).
  const auto b = BootstrapMeanInterval(ZerosAndOnes(25, 4));
  CHECK(b[0] == Approx(1.0 / 25.0));
  CHECK(b[1] == Approx(8.0 / 25.0));
  // Deterministic: the same values give the same bounds; scaling by 2 scales them exactly.
  std::vector<double> v{0.3, 1.7, 0.02, 4.1, 0.9, 0.0, 2.2};
  CHECK(BootstrapMeanInterval(v) == BootstrapMeanInterval(v));
  std::vector<double> twice = v;
  for (double& x : twice) x *= 2.0;
  CHECK(BootstrapMeanInterval(twice)[0] == 2.0 * BootstrapMeanInterval(v)[0]);
  CHECK(BootstrapMeanInterval({3.0, 3.0}) == std::array<double, 2>{3.0, 3.0});
  CHECK(std::isnan(BootstrapMeanInterval({3.0})[1]));
}

TEST_CASE("summary intervals stay in the metric's range and contain the mean", "[intervals]") {
  std::mt19937_64 rng(7);
  std::exponential_distribution<double> heavy(50.0);
  for (int rep = 0; rep < 50; ++rep) {
    // Mostly zeros with a few large values: the t-interval of such data goes below 0.
    std::vector<double> v(30, 0.0);
    for (int i = 0; i < 3; ++i) v[rng() % v.size()] = std::min(1.0, heavy(rng));
    const double mean = [&] {
      double s = 0;
      for (double x : v) s += x;
      return s / static_cast<double>(v.size());
    }();
    for (const MetricRange range : {MetricRange::kUnitInterval, MetricRange::kNonNegative}) {
      const MetricSummary s = Summarize(v, range);
      if (s.std == 0) continue;
      CHECK(s.ci_lo >= 0.0);
      CHECK(s.ci_lo <= mean);
      CHECK(s.ci_hi >= mean);
      if (range == MetricRange::kUnitInterval) CHECK(s.ci_hi <= 1.0);
    }
  }
  CHECK(MetricRangeOf("misclassification") == MetricRange::kUnitInterval);
  CHECK(MetricRangeOf("flow_outside_share") == MetricRange::kUnitInterval);
  CHECK(MetricRangeOf("e_beta") == MetricRange::kNonNegative);
  CHECK(MetricRangeOf("fp") == MetricRange::kNonNegative);
  CHECK(MetricRangeOf("rel_err_a") == MetricRange::kNonNegative);
  CHECK_THROWS_AS(MetricRangeOf("wall_ms"), std::logic_error);
}
