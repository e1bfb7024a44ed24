// RLS against batch least squares with the same prior, forgetting, and degenerate data.
#include <catch2/catch.hpp>

#include <bit>
#include <cmath>
#include <cstdint>

#include <Eigen/Dense>

#include "core/estimators/estimator.hpp"
#include "core/estimators/rls.hpp"
#include "sim/measurement.hpp"

namespace hysid {
namespace {

// Batch ridge solution (I/p0 + ΣΦᵀΦ)⁻¹(θ0/p0 + ΣΦᵀy).
Vec BatchRidge(const Mat& phi, const Vec& y, const Vec& theta0, double p0) {
  const Eigen::Index p = phi.cols();
  const Mat a = Mat::Identity(p, p) / p0 + phi.transpose() * phi;
  const Vec b = theta0 / p0 + phi.transpose() * y;
  return a.ldlt().solve(b);
}

Mat RandomRows(long rows, int cols, std::uint64_t seed) {
  Mat m(rows, cols);
  for (long r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      m(r, c) = StandardNormals(NoiseKey{seed, 0}, RandomPurpose::kMeasurementNoise,
                                static_cast<std::uint64_t>(r), static_cast<std::uint64_t>(c))
                    .v[0];
    }
  }
  return m;
}

TEST_CASE("RLS equals batch least squares with the same prior, scalar rows", "[rls]") {
  const Mat phi = RandomRows(500, 3, 11);
  Vec theta(3);
  theta << 2.0, -0.5, 0.25;
  const Vec noise = RandomRows(500, 1, 12).col(0) * 0.1;
  const Vec y = phi * theta + noise;
  for (double p0 : {1e-2, 1.0, 1e4}) {
    EstimatorSettings settings;
    settings.p0 = p0;
    Vec theta0(3);
    theta0 << 0.3, 0.1, -0.2;
    auto rls = MakeEstimator(settings, theta0);
    for (long k = 0; k < phi.rows(); ++k) rls->Update(phi.row(k), y.segment(k, 1));
    const Vec batch = BatchRidge(phi, y, theta0, p0);
    INFO("p0 = " << p0);
    CHECK((rls->estimate() - batch).norm() <= 1e-9 * batch.norm());
    CHECK(rls->status() == EstimatorStatus::kOk);
  }
}

TEST_CASE("RLS equals batch least squares with vector measurements", "[rls]") {
  const Mat phi = RandomRows(600, 2, 21);
  Vec theta(2);
  theta << -1.0, 3.0;
  const Vec y = phi * theta + RandomRows(600, 1, 22).col(0) * 0.2;
  EstimatorSettings settings;
  settings.p0 = 10.0;
  auto rls = MakeEstimator(settings, Vec::Zero(2));
  for (long k = 0; k < phi.rows(); k += 3) rls->Update(phi.middleRows(k, 3), y.segment(k, 3));
  const Vec batch = BatchRidge(phi, y, Vec::Zero(2), 10.0);
  CHECK((rls->estimate() - batch).norm() <= 1e-9 * batch.norm());
  // The covariance is P = (I/p0 + ΦᵀΦ)⁻¹ and symmetric.
  const Mat p = *rls->covariance_matrix();
  const Mat expected = (Mat::Identity(2, 2) / 10.0 + phi.transpose() * phi).inverse();
  CHECK((p - expected).norm() <= 1e-9 * expected.norm());
  CHECK(p == p.transpose());
}

TEST_CASE("RLS reads a strided row (middleRows of a column-major matrix) correctly", "[rls]") {
  // Regression test: the scalar path indexed φ as contiguous; a 1×p block of a column-major matrix
  // binds to ConstMatRef without a copy, with outerStride() = the parent's rows.
  const Mat phi = RandomRows(300, 3, 41);
  Vec theta(3);
  theta << 1.0, -2.0, 0.5;
  const Vec y = phi * theta;
  EstimatorSettings settings;
  auto by_block = MakeEstimator(settings, Vec::Zero(3));
  auto by_row = MakeEstimator(settings, Vec::Zero(3));
  for (long k = 0; k < phi.rows(); ++k) {
    by_block->Update(phi.middleRows(k, 1), y.segment(k, 1));
    by_row->Update(phi.row(k), y.segment(k, 1));
  }
  CHECK((by_block->estimate() - by_row->estimate()).norm() <= 1e-12);
  CHECK((by_block->estimate() - theta).norm() <= 1e-6);
}

TEST_CASE("RLS with forgetting tracks a parameter change and equals the weighted LS closed form", "[rls]") {
  const double lambda = 0.98;
  const Mat phi = RandomRows(400, 2, 31);
  Vec y(400);
  Vec before(2), after(2);
  before << 1.0, 1.0;
  after << -2.0, 0.5;
  for (long k = 0; k < 400; ++k) y[k] = phi.row(k).dot(k < 200 ? before : after);
  EstimatorSettings settings;
  settings.forgetting = lambda;
  settings.p0 = 1e6;
  auto rls = MakeEstimator(settings, Vec::Zero(2));
  for (long k = 0; k < 400; ++k) rls->Update(phi.row(k), y.segment(k, 1));
  // Exponentially weighted LS: min Σ λ^{N−k}(y_k − φ_kθ)² + λ^N θᵀθ/p0.
  Mat a = Mat::Identity(2, 2) * std::pow(lambda, 400) / 1e6;
  Vec b = Vec::Zero(2);
  for (long k = 0; k < 400; ++k) {
    const double w = std::pow(lambda, 399 - k);
    a += w * phi.row(k).transpose() * phi.row(k);
    b += w * phi.row(k).transpose() * y[k];
  }
  const Vec weighted = a.ldlt().solve(b);
  CHECK((rls->estimate() - weighted).norm() <= 1e-8 * weighted.norm());
  // Old data keeps weight λ^200 ≈ 0.018: the estimate is near the new value, far from the old.
  CHECK((rls->estimate() - after).norm() <= 0.1);
  CHECK((rls->estimate() - before).norm() >= 2.5);
}

TEST_CASE("RLS stays finite on unexciting data with forgetting", "[rls]") {
  EstimatorSettings settings;
  settings.forgetting = 0.9;
  auto rls = MakeEstimator(settings, Vec::Zero(2));
  Mat zero = Mat::Zero(1, 2);
  Vec y = Vec::Zero(1);
  for (int k = 0; k < 100000; ++k) rls->Update(zero, y);
  CHECK(rls->estimate().allFinite());
  CHECK(rls->covariance_matrix()->allFinite());
  CHECK(rls->covariance_matrix()->trace() <= 2 * settings.p0 / 0.9 * (1 + 1e-12));
  CHECK(rls->status() == EstimatorStatus::kNotExcited);
  // A non-finite row is skipped and counted.
  Mat bad(1, 2);
  bad << std::nan(""), 1.0;
  rls->Update(bad, y);
  CHECK(rls->skipped() == 1);
  CHECK(rls->estimate().allFinite());
  // Wrong sizes and unknown names are errors.
  CHECK_THROWS_WITH(rls->Update(Mat::Zero(1, 3), y), Catch::Contains("3"));
  CHECK_THROWS_WITH(ParseKind<EstimatorKind>("kalman"), Catch::Contains("known: rls"));
  EstimatorSettings bad_forgetting;
  bad_forgetting.forgetting = 1.5;
  CHECK_THROWS_WITH(MakeEstimator(bad_forgetting, Vec::Zero(2)), Catch::Contains("forgetting"));
}

TEST_CASE("the two-parameter scalar update equals the general-p loop bit for bit", "[rls]") {
  // detail::Rls2State (the identifier's per-sample path, and ScalarRlsUpdate<2>) against
  // ScalarRlsUpdate<0>, the loop for any p, on the same rows: without and with forgetting (the
  // division by λ taken while trace(P) is below max_trace, skipped above), and a row whose φᵀPφ + λ
  // is not positive (nothing changes).
  const Mat rows = RandomRows(400, 3, 11);
  for (const double lambda : {1.0, 0.95}) {
    INFO("lambda " << lambda);
    const double max_trace = 2.0 * 100.0;
    double theta[2] = {0.5, -1.0}, pp[4] = {100.0, 0.0, 0.0, 100.0}, g[2];
    detail::Rls2State r{theta[0], theta[1], pp[0], pp[1], pp[3]};
    long scaled = 0;
    for (Eigen::Index k = 0; k < rows.rows(); ++k) {
      const double phi[2] = {rows(k, 0), rows(k, 1)};
      const double y = 0.3 * phi[0] - 2.0 * phi[1] + 0.1 * rows(k, 2);
      const bool general = detail::ScalarRlsUpdate<0>(2, pp, theta, g, phi, 1, y, lambda, max_trace);
      const bool two = r.Update(phi[0], phi[1], y, lambda, max_trace);
      REQUIRE(general == two);
      REQUIRE(r.t0 == theta[0]);
      REQUIRE(r.t1 == theta[1]);
      REQUIRE(r.p00 == pp[0]);
      REQUIRE(r.p10 == pp[1]);
      REQUIRE(pp[1] == pp[2]);
      REQUIRE(r.p11 == pp[3]);
      scaled += pp[0] + pp[3] < max_trace ? 1 : 0;
    }
    if (lambda != 1.0) CHECK(scaled > 0);
    const double before[5] = {r.t0, r.t1, r.p00, r.p10, r.p11};
    CHECK_FALSE(r.Update(1.0, 0.0, 1.0, -1e9, max_trace));  // φᵀPφ + λ < 0
    CHECK(before[0] == r.t0);
    CHECK(before[2] == r.p00);
    CHECK(before[4] == r.p11);
  }
}

TEST_CASE("the two-parameter update keeps the general loop's signed zeros bit for bit", "[rls]") {
  // Rls2State::Update takes Pφ as a + b and adds the leading 0 of the general loop's 0 + a + b
  // beside the chain; rows and states with ±0 entries, where only the sign of a zero can differ,
  // compared bit by bit (== does not see the sign of a zero).
  const double values[] = {-0.0, 0.0, 1.0, -2.5};
  auto same = [](double x, double y) { return std::bit_cast<std::uint64_t>(x) == std::bit_cast<std::uint64_t>(y); };
  long zero_gains = 0;
  for (const double f0 : values) {
    for (const double f1 : values) {
      for (const double p10 : {-0.0, 0.0, 0.5}) {
        for (const double t : {-0.0, 0.0, 3.0}) {
          for (const double y : {-0.0, 0.0, 1.5}) {
            double theta[2] = {t, -t}, pp[4] = {2.0, p10, p10, 4.0}, g[2];
            detail::Rls2State r{theta[0], theta[1], pp[0], pp[1], pp[3]};
            const double phi[2] = {f0, f1};
            const bool general = detail::ScalarRlsUpdate<0>(2, pp, theta, g, phi, 1, y, 1.0, 6.0);
            REQUIRE(general == r.Update(f0, f1, y, 1.0, 6.0));
            REQUIRE(same(r.t0, theta[0]));
            REQUIRE(same(r.t1, theta[1]));
            REQUIRE(same(r.p00, pp[0]));
            REQUIRE(same(r.p10, pp[1]));
            REQUIRE(same(r.p11, pp[3]));
            zero_gains += g[0] == 0.0 ? 1 : 0;
          }
        }
      }
    }
  }
  CHECK(zero_gains > 0);
}

}  // namespace
}  // namespace hysid
