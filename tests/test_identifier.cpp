// The identifier end to end against the simulator's ground truth.
#include <catch2/catch.hpp>

#include <cmath>

#include "core/identifier.hpp"
#include "core/metrics.hpp"
#include "core/models/bouncing_ball.hpp"
#include "core/models/impact_msd.hpp"
#include "core/models/impact_pendulum.hpp"
#include "sim/measurement.hpp"
#include "sim/simulator.hpp"

namespace hysid {
namespace {

Vec DefaultX0(const Model& m) {
  const auto& v = m.spec().default_x0;
  return Eigen::Map<const Vec>(v.data(), static_cast<Eigen::Index>(v.size()));
}

TEST_CASE("noise-free §5: all 14 jumps, no false ones, e_alpha < 1e-4", "[identify]") {
  const Model model{ImpactMsd{}};
  const Trajectory traj = Simulate(model, DefaultX0(model), SampleGrid{20.0, 5e-4});
  REQUIRE(traj.status.completed());
  IdentifierSettings settings;  // paper defaults: rls, r = 220, tau0 = 1e5
  const IdentifyResult r = Identify(model, traj.x, traj.dt, settings);
  const Confusion c = CompareJumps(traj.j, r.gamma);
  CHECK(c.tp == 14);
  CHECK(c.fp == 0);
  CHECK(c.fn == 0);
  const ParameterErrors e = CompareParameters(model, r.alpha_hat, r.beta_hat);
  INFO("alpha_hat " << r.alpha_hat.transpose() << "  beta_hat " << r.beta_hat.transpose());
  INFO("e_alpha " << e.e_alpha << "  e_beta " << e.e_beta);
  CHECK(e.e_alpha < 1e-4);
  CHECK(e.e_beta < 1e-3);
}


TEST_CASE("bouncing ball at sigma 0: g and lambda within 1 %", "[identify]") {
  // Affine flow (gravity): the bound is taken in homogeneous coordinates ("auto" picks it).
  const Model model{BouncingBall{}};
  const Trajectory traj = Simulate(model, DefaultX0(model), SampleGrid{3.0, 1e-3});
  REQUIRE(traj.status.completed());
  REQUIRE(traj.jumps.size() == 6);
  IdentifierSettings settings;
  settings.detector.r = 20.0;
  const IdentifyResult r = Identify(model, traj.x, traj.dt, settings);
  const Confusion c = CompareJumps(traj.j, r.gamma);
  CHECK(c.tp == 6);
  CHECK(c.fp == 0);
  INFO("g^ " << r.alpha_hat[1] << " lambda^ " << r.beta_hat[1] << " mu^ " << r.beta_hat[2]);
  CHECK(std::abs(r.alpha_hat[1] - 9.81) <= 0.01 * 9.81);
  CHECK(std::abs(r.beta_hat[1] - 0.8) <= 0.01 * 0.8);
}

TEST_CASE("bouncing ball: the paper's bound without homogeneous coordinates flags flow as jumps",
          "[identify]") {
  // Near the apex f(ξ) ≈ (0, −g) while the identified-row Jacobian is 0: τ̂ = 0 < D_δt ξ ≈ g.
  const Model model{BouncingBall{}};
  const Trajectory traj = Simulate(model, DefaultX0(model), SampleGrid{3.0, 1e-3});
  IdentifierSettings settings;
  settings.detector.r = 20.0;
  settings.detector.bound = "paper";
  const IdentifyResult r = Identify(model, traj.x, traj.dt, settings);
  const Confusion c = CompareJumps(traj.j, r.gamma);
  CHECK(c.fp > 1000);
}

TEST_CASE("impact pendulum at sigma 0: a and b within 1 %", "[identify]") {
  const Model model{ImpactPendulum{}};
  const Trajectory traj = Simulate(model, DefaultX0(model), SampleGrid{20.0, 1e-3});
  REQUIRE(traj.status.completed());
  IdentifierSettings settings;
  settings.detector.r = 20.0;
  const IdentifyResult r = Identify(model, traj.x, traj.dt, settings);
  const Confusion c = CompareJumps(traj.j, r.gamma);
  CHECK(c.fp == 0);
  CHECK(c.fn == 0);
  INFO("a^ " << r.alpha_hat[1] << " b^ " << r.alpha_hat[2]);
  CHECK(std::abs(r.alpha_hat[1] - model.alpha()[1]) <= 0.01 * model.alpha()[1]);
  CHECK(std::abs(r.alpha_hat[2] - model.alpha()[2]) <= 0.01 * model.alpha()[2]);
}

TEST_CASE("the §5 detector with r too large misses every jump; with noise and r = 20 it floods",
          "[identify]") {
  const Model model{ImpactMsd{}};
  const Trajectory traj = Simulate(model, DefaultX0(model), SampleGrid{20.0, 5e-4});
  IdentifierSettings settings;
  settings.detector.r = 1000.0;  // D/τ̂ at a jump ≈ 2/(r·L̂·δt) = 0.8 < 1
  CHECK(CompareJumps(traj.j, Identify(model, traj.x, traj.dt, settings).gamma).tp == 0);
  settings.detector.r = 20.0;
  const Mat y = AddMeasurementNoise(traj.x, Vec::Constant(2, 0.25), NoiseKey{1, 0});
  CHECK(CompareJumps(traj.j, Identify(model, y, traj.dt, settings).gamma).fp > 1000);
}

TEST_CASE("metrics: confusion counts and parameter errors by hand", "[metrics]") {
  const std::vector<int> j{0, 0, 1, 1, 2, 2, 2};
  const std::vector<std::uint8_t> g{0, 0, 1, 1, 0, 0, 0};
  const Confusion c = CompareJumps(j, g);
  CHECK(c.tp == 1);
  CHECK(c.fp == 1);
  CHECK(c.fn == 1);
  CHECK(c.tn == 3);
  CHECK(c.misclassification() == Approx(2.0 / 6.0));
  CHECK(c.precision() == 0.5);
  CHECK(c.recall() == 0.5);
  CHECK_THROWS(CompareJumps(j, std::vector<std::uint8_t>(3)));
  const Model model{ImpactMsd{}};
  Vec a = model.alpha(), b = model.beta();
  a[1] += 3.0;
  b[2] += 4.0;
  const ParameterErrors e = CompareParameters(model, a, b);
  CHECK(e.e_alpha == Approx(3.0));
  CHECK(e.e_beta == Approx(4.0));
  CHECK(e.rel_alpha == Approx(3.0 / std::hypot(5.0, 0.1)));
}

TEST_CASE("true smoothness bound of impact-msd is ‖(a, b)‖ times the trapezoid state norm",
          "[metrics]") {
  const Model model{ImpactMsd{}};
  Mat x(2, 3);
  x << 3, 0, 4,  //
      4, 1, 0;
  const auto tau = TrueSmoothnessBound(model, x, DetectorSettings{});
  const double l = std::hypot(5.0, 0.1);
  CHECK(tau[0] == 0.0);
  CHECK(tau[1] == Approx(0.5 * l * (1.0 + 5.0)));
  CHECK(tau[2] == Approx(0.5 * l * (4.0 + 1.0)));
}

}  // namespace
}  // namespace hysid
