// Counter-based measurement noise: statistics, and identical draws whatever thread draws them.
#include <catch2/catch.hpp>

#include <thread>

#include "sim/measurement.hpp"

namespace hysid {
namespace {

TEST_CASE("noise has the requested mean and per-component standard deviation", "[noise]") {
  const long samples = 200000;
  const Mat x = Mat::Zero(2, samples);
  Vec sigma(2);
  sigma << 0.25, 2.0;
  const Mat y = AddMeasurementNoise(x, sigma, NoiseKey{7, 3});
  for (int i = 0; i < 2; ++i) {
    const double mean = y.row(i).mean();
    const double sd = std::sqrt((y.row(i).array() - mean).square().sum() / (samples - 1));
    // Standard error of the mean σ/√N; of the s.d. ≈ σ/√(2N). Allow 5 standard errors.
    CHECK(std::abs(mean) <= 5 * sigma[i] / std::sqrt(samples));
    CHECK(std::abs(sd - sigma[i]) <= 5 * sigma[i] / std::sqrt(2.0 * samples));
  }
  // Components are uncorrelated.
  const double corr = (y.row(0).array() * y.row(1).array()).mean() / (sigma[0] * sigma[1]);
  CHECK(std::abs(corr) <= 5 / std::sqrt(samples));
}

TEST_CASE("same key gives the same noise on one thread and on two", "[noise]") {
  const Mat x = Mat::Zero(2, 10001);
  const Vec sigma = Vec::Constant(2, 0.25);
  const Mat serial = AddMeasurementNoise(x, sigma, NoiseKey{42, 5});
  // Two threads each draw half of the columns, by sample index, in reverse order.
  Mat parallel(2, x.cols());
  auto draw = [&](long begin, long end) {
    for (long k = end - 1; k >= begin; --k) {
      const Normal4 n = StandardNormals(NoiseKey{42, 5}, RandomPurpose::kMeasurementNoise,
                                        static_cast<std::uint64_t>(k));
      parallel(0, k) = sigma[0] * n.v[0];
      parallel(1, k) = sigma[1] * n.v[1];
    }
  };
  std::thread a(draw, 0, 5000), b(draw, 5000, x.cols());
  a.join();
  b.join();
  CHECK(parallel == serial);
  // A different stream or seed gives different numbers.
  CHECK(AddMeasurementNoise(x, sigma, NoiseKey{42, 6}) != serial);
  CHECK(AddMeasurementNoise(x, sigma, NoiseKey{43, 5}) != serial);
}

TEST_CASE("zero sigma leaves the state unchanged and bad sigma is rejected", "[noise]") {
  Mat x(2, 3);
  x << 1, 2, 3, 4, 5, 6;
  CHECK(AddMeasurementNoise(x, Vec::Zero(2), NoiseKey{}) == x);
  CHECK_THROWS_WITH(AddMeasurementNoise(x, Vec::Constant(2, -1.0), NoiseKey{}),
                    Catch::Contains("sigma"));
  CHECK_THROWS(AddMeasurementNoise(x, Vec::Zero(3), NoiseKey{}));
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
