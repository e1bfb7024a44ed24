// Counter-based measurement noise: the distribution of the ziggurat stream (moments, a
// Kolmogorov–Smirnov and a χ² test at fixed seeds), identical draws whatever thread draws them or
// in what slices, and the earlier per-sample Box–Muller draw.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <thread>
#include <vector>

#include "sim/measurement.hpp"

namespace hysid {
namespace {

double NormalCdf(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }

std::vector<double> Stream(const NoiseKey& key, std::size_t count) {
  std::vector<double> v(count);
  FillStandardNormals(key, 0, v.data(), count);
  return v;
}

TEST_CASE("the normal stream has the moments of N(0, 1)", "[noise]") {
  const std::size_t n = 2000000;
  const std::vector<double> v = Stream(NoiseKey{2020, 7, {0, 3}}, n);
  double m1 = 0, m2 = 0, m3 = 0, m4 = 0;
  for (double x : v) m1 += x, m2 += x * x, m3 += x * x * x, m4 += x * x * x * x;
  const double N = static_cast<double>(n);
  m1 /= N, m2 /= N, m3 /= N, m4 /= N;
  // Standard errors of the sample moments of N(0, 1): √(1/N), √(2/N), √(15/N), √(96/N). 5 of them.
  CHECK(std::abs(m1) <= 5 * std::sqrt(1 / N));
  CHECK(std::abs(m2 - 1) <= 5 * std::sqrt(2 / N));
  CHECK(std::abs(m3) <= 5 * std::sqrt(15 / N));
  CHECK(std::abs(m4 - 3) <= 5 * std::sqrt(96 / N));
}

TEST_CASE("the normal stream passes Kolmogorov–Smirnov and χ² tests (fixed seeds)", "[noise]") {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const std::size_t n = 1000000;
    std::vector<double> v = Stream(NoiseKey{seed, 0}, n);
    std::sort(v.begin(), v.end());
    double d = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double f = NormalCdf(v[i]);
      d = std::max({d, f - static_cast<double>(i) / n, static_cast<double>(i + 1) / n - f});
    }
    // KS critical value at α = 0.001: 1.9495/√n.
    CHECK(d < 1.9495 / std::sqrt(static_cast<double>(n)));

    // χ² on 64 bins: edges −4 … 4 in steps of 0.125 (the ziggurat's layers are finer in the middle)
    // and two open tail bins beyond ±4 — together 66 bins. Critical value at α = 0.001 for 65
    // degrees of freedom (Wilson–Hilferty): 65·(1 − 2/585 + 3.0902·√(2/585))³ ≈ 107.6.
    std::vector<double> edges{-INFINITY};
    for (int i = -32; i <= 32; ++i) edges.push_back(0.125 * i);
    edges.push_back(INFINITY);
    double chi2 = 0;
    for (std::size_t b = 0; b + 1 < edges.size(); ++b) {
      const auto lo = std::lower_bound(v.begin(), v.end(), edges[b]);
      const auto hi = std::lower_bound(v.begin(), v.end(), edges[b + 1]);
      const double observed = static_cast<double>(hi - lo);
      const double expected = n * (NormalCdf(edges[b + 1]) - NormalCdf(edges[b]));
      chi2 += (observed - expected) * (observed - expected) / expected;
    }
    CHECK(chi2 < 107.6);
    // The tail beyond r = 3.654 (probability 2.58e-4 both sides) is drawn: ≈ 258 of 1e6.
    const double tail = static_cast<double>(
        std::count_if(v.begin(), v.end(), [](double x) { return std::abs(x) > 3.6541528853610088; }));
    const double expected_tail = n * 2 * (1 - NormalCdf(3.6541528853610088));
    CHECK(std::abs(tail - expected_tail) <= 5 * std::sqrt(expected_tail));
  }
}

TEST_CASE("a stream is the same drawn whole, in slices, on two threads, or in reverse", "[noise]") {
  const NoiseKey key{42, 5, {1, 0x3f40624dd2f1a9fcull}};
  const std::size_t n = 50001;  // odd: slices end inside a block
  const std::vector<double> whole = Stream(key, n);
  std::vector<double> sliced(n);
  auto draw = [&](std::size_t begin, std::size_t end) {
    // Backwards, three normals at a time, so that slices start and end inside Philox blocks.
    for (std::size_t hi = end; hi > begin;) {
      const std::size_t lo = hi >= begin + 3 ? hi - 3 : begin;
      FillStandardNormals(key, lo, sliced.data() + lo, hi - lo);
      hi = lo;
    }
  };
  std::thread a(draw, 0, 20001), b(draw, 20001, n);
  a.join();
  b.join();
  CHECK(sliced == whole);
  // Forwards, six at a time from an offset of 2: whole blocks of four alone, and the pairs of blocks.
  for (std::size_t width : {6, 13}) {
    std::vector<double> forward(n);
    FillStandardNormals(key, 0, forward.data(), 2);
    for (std::size_t lo = 2; lo < n; lo += width) {
      FillStandardNormals(key, lo, forward.data() + lo, std::min(width, n - lo));
    }
    CHECK(forward == whole);
  }
  // Another seed, stream or sub word gives another stream.
  CHECK(Stream(NoiseKey{43, 5, {1, 0x3f40624dd2f1a9fcull}}, 8) !=
        std::vector<double>(whole.begin(), whole.begin() + 8));
  CHECK(Stream(NoiseKey{42, 6, {1, 0x3f40624dd2f1a9fcull}}, 8) !=
        std::vector<double>(whole.begin(), whole.begin() + 8));
  CHECK(Stream(NoiseKey{42, 5, {2, 0x3f40624dd2f1a9fcull}}, 8) !=
        std::vector<double>(whole.begin(), whole.begin() + 8));
  CHECK(Stream(NoiseKey{42, 5, {1, 0}}, 8) != std::vector<double>(whole.begin(), whole.begin() + 8));
}

TEST_CASE("AddMeasurementNoise is x + diag(σ)·E with E the stream, column by column", "[noise]") {
  const long samples = 200000;
  Mat x = Mat::Zero(2, samples);
  x.row(0).setLinSpaced(samples, -3.0, 5.0);
  Vec sigma(2);
  sigma << 0.25, 2.0;
  const NoiseKey key{7, 3};
  const Mat y = AddMeasurementNoise(x, sigma, key);
  const std::vector<double> e = Stream(key, 2 * samples);
  bool same = true;
  for (long k = 0; k < samples; ++k) {
    for (int i = 0; i < 2; ++i) same = same && y(i, k) == x(i, k) + sigma[i] * e[std::size_t(2 * k + i)];
  }
  CHECK(same);
  const Mat noise = y - x;
  for (int i = 0; i < 2; ++i) {
    const double mean = noise.row(i).mean();
    const double sd = std::sqrt((noise.row(i).array() - mean).square().sum() / (samples - 1));
    CHECK(std::abs(mean) <= 5 * sigma[i] / std::sqrt(samples));
    CHECK(std::abs(sd - sigma[i]) <= 5 * sigma[i] / std::sqrt(2.0 * samples));
  }
  const double corr = (noise.row(0).array() * noise.row(1).array()).mean() / (sigma[0] * sigma[1]);
  CHECK(std::abs(corr) <= 5 / std::sqrt(samples));
}

TEST_CASE("the per-sample draw is Box–Muller on one Philox call per sample", "[noise]") {
  const Mat x = Mat::Zero(2, 10001);
  const Vec sigma = Vec::Constant(2, 0.25);
  const Mat serial = AddMeasurementNoisePerSample(x, sigma, NoiseKey{42, 5});
  Mat parallel(2, x.cols());
  auto draw = [&](long begin, long end) {
    for (long k = end - 1; k >= begin; --k) {
      const Normal4 n =
          StandardNormals(NoiseKey{42, 5}, RandomPurpose::kMeasurementNoise, static_cast<std::uint64_t>(k));
      parallel(0, k) = sigma[0] * n.v[0];
      parallel(1, k) = sigma[1] * n.v[1];
    }
  };
  std::thread a(draw, 0, 5000), b(draw, 5000, x.cols());
  a.join();
  b.join();
  CHECK(parallel == serial);
  CHECK(AddMeasurementNoisePerSample(x, sigma, NoiseKey{42, 6}) != serial);
}

TEST_CASE("zero sigma leaves the state unchanged and bad sigma is rejected", "[noise]") {
  Mat x(2, 3);
  x << 1, 2, 3, 4, 5, 6;
  for (auto* add : {&AddMeasurementNoise, &AddMeasurementNoisePerSample}) {
    CHECK(add(x, Vec::Zero(2), NoiseKey{}) == x);
    CHECK_THROWS_WITH(add(x, Vec::Constant(2, -1.0), NoiseKey{}), Catch::Contains("sigma"));
    CHECK_THROWS(add(x, Vec::Zero(3), NoiseKey{}));
  }
}

TEST_CASE("uniforms lie in (0, 1)", "[noise]") {
  double lo = 1, hi = 0;
  for (std::uint64_t k = 0; k < 10000; ++k) {
    const Uniform4 u = Uniforms(NoiseKey{1, 0}, RandomPurpose::kInitialState, k);
    for (double v : u.v) lo = std::min(lo, v), hi = std::max(hi, v);
  }
  CHECK(lo > 0.0);
  CHECK(hi < 1.0);
  CHECK(lo < 1e-3);
  CHECK(hi > 1 - 1e-3);
}

}  // namespace
}  // namespace hysid
