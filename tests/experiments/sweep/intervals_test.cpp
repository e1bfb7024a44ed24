// The range-respecting intervals of summary.csv: the Wilson interval against its closed form and
// published values, the rate interval's effective sample size for 0/1 data, the percentile bootstrap
// against the exact binomial quantiles of resampled 0/1 data and a sorted reference, its plans equal to
// it bit for bit (shared by threads), and both intervals staying inside the range.
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <catch2/catch.hpp>
#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/parallel_for.h>

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

// The percentile bootstrap as specified (intervals.hpp), written plainly: B resamples drawn by
// mt19937_64(kBootstrapSeed) mod n, each mean summed in draw order, all means sorted, quantiles
// interpolated at q·(B − 1).
std::array<double, 2> SortedBootstrap(const std::vector<double>& v) {
  std::mt19937_64 rng(kBootstrapSeed);
  const std::uint64_t n = v.size();
  std::vector<double> means;
  for (int b = 0; b < kBootstrapResamples; ++b) {
    double sum = 0;
    for (std::uint64_t k = 0; k < n; ++k) sum += v[rng() % n];
    means.push_back(sum / static_cast<double>(n));
  }
  std::sort(means.begin(), means.end());
  const auto quantile = [&](double q) {
    const double pos = q * (kBootstrapResamples - 1);
    const auto i = static_cast<std::size_t>(pos);
    return means[i] + (pos - static_cast<double>(i)) * (means[i + 1] - means[i]);
  };
  return {quantile(0.025), quantile(0.975)};
}

// Non-negative values of n = 2 … 2 + count − 1 with ties, zeros and a wide spread.
std::vector<std::vector<double>> VariedSamples(int count) {
  std::mt19937_64 rng(3);
  std::lognormal_distribution<double> spread(0.0, 2.0);
  std::vector<std::vector<double>> out;
  for (int n = 2; n < 2 + count; ++n) {
    std::vector<double> v(static_cast<std::size_t>(n));
    for (double& x : v) x = rng() % 4 == 0 ? 0.0 : spread(rng);
    if (n % 5 == 0) v[1] = v[0];
    out.push_back(std::move(v));
  }
  return out;
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

TEST_CASE("bootstrap interval: a plan and a sorted reference give the same bits", "[intervals]") {
  BootstrapPlans plans;
  for (const std::vector<double>& v : VariedSamples(120)) {
    const auto reference = SortedBootstrap(v);
    CHECK(BootstrapMeanInterval(v) == reference);
    CHECK(BootstrapPlan(v.size()).MeanInterval(v) == reference);
    CHECK(plans.MeanInterval(v) == reference);
    CHECK(plans.MeanInterval(v) == reference);  // the plan made by the call before
  }
  // Beyond what the plans may hold, the draws are made per call: the same bounds.
  const std::size_t big = BootstrapPlans::kMaxPlanIndices / kBootstrapResamples + 1;
  std::vector<double> v(big);
  for (std::size_t i = 0; i < big; ++i) v[i] = static_cast<double>((i * 7919) % 1000) * 1e-3;
  CHECK(plans.MeanInterval(v) == SortedBootstrap(v));
}

TEST_CASE("bootstrap plans shared by threads give what one thread gives", "[intervals]") {
  const std::vector<std::vector<double>> samples = VariedSamples(60);
  std::vector<std::array<double, 2>> serial;
  for (const auto& v : samples) serial.push_back(BootstrapMeanInterval(v));
  const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 4);
  for (int rep = 0; rep < 3; ++rep) {
    BootstrapPlans plans;
    std::vector<std::array<double, 2>> parallel(samples.size() * 4);
    // Each size asked for by four tasks at once, so threads race to make its plan.
    tbb::parallel_for(std::size_t{0}, parallel.size(),
                      [&](std::size_t i) { parallel[i] = plans.MeanInterval(samples[i / 4]); });
    for (std::size_t i = 0; i < parallel.size(); ++i) CHECK(parallel[i] == serial[i / 4]);
  }
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
