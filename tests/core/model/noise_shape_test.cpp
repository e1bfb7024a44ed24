// Noise covariance shapes of the flow and jump regressions (closed forms and Monte Carlo on the
// regression rows themselves), and the MAD estimate of σ on a simulated trajectory.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "core/builtin/impact_msd.hpp"
#include "core/builtin/impact_pendulum.hpp"
#include "core/model/noise_shape.hpp"
#include "core/model/regression.hpp"
#include "sim/measurement.hpp"
#include "sim/simulator.hpp"
#include "tests/testing/vec.hpp"

namespace hysid {
namespace {

using testing::V;

TEST_CASE("noise shapes of impact-msd: closed forms", "[noise_shape]") {
  const Model model(ImpactMsd{});
  const Vec sigma = V(0.05, 0.2);
  const double dt = 5e-4;
  Mat states(2, 2);
  states << 3.0, 0.0, -1.0, 4.0;  // affine φ: C does not depend on the state
  const Mat flow = FlowNoiseShape(model, sigma, dt, states);
  Mat expected = Mat::Zero(3, 3);
  // Row v: φ_u = (δt/2)[−(x_k + x_{k−1}), −(v_k + v_{k−1})], y = Δv.
  expected.diagonal() << 0.5 * dt * dt * 0.05 * 0.05, 0.5 * dt * dt * 0.2 * 0.2, 2.0 * 0.2 * 0.2;
  CHECK((flow - expected).norm() <= 1e-6 * expected.norm());
  CHECK(std::abs(flow(0, 0) - expected(0, 0)) <= 1e-6 * expected(0, 0));
  // Jump row v: ψ_u = [−v_{k−1}, 1] (the 1 is exact), y = v_k.
  const Mat jump = JumpNoiseShape(model, sigma, states);
  expected.setZero();
  expected.diagonal() << 0.04, 0.0, 0.04;
  CHECK((jump - expected).norm() <= 1e-8);
  CHECK(jump(1, 1) == 0.0);
}

// Empirical covariance of (noisy row − clean row) over many noise draws, for a fixed state pair.
Mat EmpiricalFlowNoise(const Model& model, const Vec& prev, const Vec& cur, const Vec& sigma, double dt,
                       int draws) {
  RegressionBuilder builder(model);
  const int u = static_cast<int>(builder.flow_layout().unknown.size());
  Mat phi0(1, u), phi(1, u);
  Vec y0(1), y(1);
  builder.Flow(prev, cur, dt, phi0, y0);
  Mat acc = Mat::Zero(u + 1, u + 1);
  Vec w(u + 1);
  for (int k = 0; k < draws; ++k) {
    const Normal4 n =
        StandardNormals(NoiseKey{99, 0}, RandomPurpose::kMeasurementNoise, static_cast<std::uint64_t>(k));
    const Vec p = prev + sigma.cwiseProduct(V(n.v[0], n.v[1]));
    const Vec c = cur + sigma.cwiseProduct(V(n.v[2], n.v[3]));
    builder.Flow(p, c, dt, phi, y);
    w << (phi - phi0).transpose(), y - y0;
    acc += w * w.transpose();
  }
  return acc / draws;
}

TEST_CASE("flow noise shape matches the regression rows' noise (trapezoid cross term = 0)", "[noise_shape]") {
  const double dt = 0.01;
  const int draws = 40000;
  for (const Model& model : {Model(ImpactMsd{}), Model(ImpactPendulum{})}) {
    const Vec sigma = model.name() == "impact-msd" ? V(0.05, 0.2) : V(0.01, 0.05);
    const Vec prev = V(0.8, -0.3), cur = V(0.797, -0.31);
    const Mat empirical = EmpiricalFlowNoise(model, prev, cur, sigma, dt, draws);
    Mat mid(2, 1);
    mid.col(0) = 0.5 * (prev + cur);
    const Mat c = FlowNoiseShape(model, sigma, dt, mid);
    INFO(model.name() << "\nC =\n" << c << "\nempirical =\n" << empirical);
    // Each entry within 4 standard errors of a sample second moment (≈ √(2/draws)·scale).
    for (int i = 0; i < c.rows(); ++i) {
      for (int j = 0; j < c.cols(); ++j) {
        const double scale = std::sqrt(c(i, i) * c(j, j));
        CHECK(std::abs(empirical(i, j) - c(i, j)) <= 4.0 * std::sqrt(2.0 / draws) * scale);
      }
    }
  }
}

TEST_CASE("MAD of second differences recovers sigma on a simulated trajectory", "[noise_shape]") {
  const Model model(ImpactMsd{});
  const auto spec = model.spec();
  Vec x0(2);
  x0 << spec.default_x0[0], spec.default_x0[1];
  const Trajectory traj = Simulate(model, x0, SampleGrid{10.0, 5e-4});
  REQUIRE(traj.status.completed());
  REQUIRE(!traj.jumps.empty());  // jumps are outliers the median must ignore
  for (double scale : {0.01, 0.1}) {
    const Vec sigma = V(1.0, 4.0) * scale;
    const Mat y = AddMeasurementNoise(traj.x, sigma, NoiseKey{5, 1});
    const Vec estimate = EstimateNoiseSigma(y);
    std::printf("[noise_shape] sigma (%.3f, %.3f) -> estimate (%.4f, %.4f), %zu jumps, %ld samples\n",
                sigma[0], sigma[1], estimate[0], estimate[1], traj.jumps.size(), traj.size());
    INFO("sigma scale " << scale);
    CHECK(estimate[0] == Approx(sigma[0]).epsilon(0.03));
    CHECK(estimate[1] == Approx(sigma[1]).epsilon(0.03));
  }
  // Noise-free: only δt²ξ'' remains, far below either σ above.
  CHECK(EstimateNoiseSigma(traj.x).maxCoeff() <= 1e-3);
}

TEST_CASE("sigma from second differences is the MAD of them, as EstimateNoiseSigma gives on the row",
          "[noise_shape]") {
  // d = (3, -1, 0, 5, 2): median 2, |d − 2| = (1, 3, 2, 3, 0), median 2 → σ̂ = 1.4826 · 2 / √6.
  std::vector<double> d{3.0, -1.0, 0.0, 5.0, 2.0};
  CHECK(NoiseSigmaFromSecondDifferences(d) == Approx(1.4826 * 2.0 / std::sqrt(6.0)).epsilon(1e-15));
  // A row whose second differences are those: y_{k+2} = d_k + 2y_{k+1} − y_k from y_0 = 1, y_1 = 4.
  const std::vector<double> diffs{3.0, -1.0, 0.0, 5.0, 2.0};
  Mat y(1, 7);
  y(0, 0) = 1.0;
  y(0, 1) = 4.0;
  for (int k = 0; k < 5; ++k) y(0, k + 2) = diffs[static_cast<std::size_t>(k)] + 2.0 * y(0, k + 1) - y(0, k);
  d = diffs;
  CHECK(EstimateNoiseSigma(y)[0] == NoiseSigmaFromSecondDifferences(d));
  std::vector<double> two{1.0};
  CHECK_THROWS_WITH(NoiseSigmaFromSecondDifferences(two), Catch::Contains("at least 4"));
  std::vector<double> inf{1.0, std::numeric_limits<double>::infinity()};
  CHECK_THROWS_WITH(NoiseSigmaFromSecondDifferences(inf), Catch::Contains("finite"));
}

TEST_CASE("noise shape errors name the field", "[noise_shape]") {
  const Model model(ImpactMsd{});
  const Mat states = Mat::Zero(2, 1);
  CHECK_THROWS_WITH(FlowNoiseShape(model, Vec::Ones(3), 0.01, states),
                    Catch::Contains("sigma has 3 entries"));
  CHECK_THROWS_WITH(FlowNoiseShape(model, V(0.1, -1.0), 0.01, states), Catch::Contains("sigma[1] = -1"));
  CHECK_THROWS_WITH(FlowNoiseShape(model, V(0.1, 0.1), 0.0, states), Catch::Contains("dt = 0"));
  CHECK_THROWS_WITH(JumpNoiseShape(model, V(0.1, 0.1), Mat::Zero(3, 1)), Catch::Contains("states is 3x1"));
  CHECK_THROWS_WITH(EstimateNoiseSigma(Mat::Zero(2, 3)), Catch::Contains("at least 4"));
}

}  // namespace
}  // namespace hysid
