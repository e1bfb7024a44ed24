// Simulate and SimulateSensitivities run one hybrid loop: the same jumps and the same stop where a
// Zeno rule decides the outcome (a stiff spring's constant jump intervals, true accumulation of a
// bouncing ball, a chain of jumps at one instant), and the states alone bit for bit.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>
#include <vector>

#include "core/builtin/bouncing_ball.hpp"
#include "core/builtin/impact_msd.hpp"
#include "sim/sensitivity/sensitivity.hpp"

namespace hysid {
namespace {

struct Pair {
  Trajectory plain;
  SensitivityTrajectory sens;
};

Pair RunBoth(const Model& model, const SampleGrid& grid, const SimOptions& sim = {}) {
  const Vec x0 = DefaultState(model);
  return {Simulate(model, x0, grid, sim),
          SimulateSensitivities(model, HybridParameters::Of(model, x0), Unknowns::Of(model), grid, {.sim = sim, .sensitivities = true})};
}

// Same stop, same jump count, jump times within `time_tolerance`, same samples' jump counters.
void CheckAgree(const Pair& p, SimStop stop, double time_tolerance) {
  const Trajectory& a = p.plain;
  const Trajectory& b = p.sens.trajectory;
  INFO("Simulate: " << a.status.message << "\nSimulateSensitivities: " << b.status.message);
  CHECK(a.status.stop == stop);
  CHECK(b.status.stop == stop);
  REQUIRE(a.jumps.size() == b.jumps.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < a.jumps.size(); ++i) worst = std::max(worst, std::abs(a.jumps[i].t - b.jumps[i].t));
  INFO("largest jump-time difference " << worst);
  CHECK(worst <= time_tolerance);
  REQUIRE(a.size() == b.size());
  CHECK(a.j == b.j);
  CHECK(p.sens.sensitivities.cols() == b.size());
  CHECK(p.sens.jump_time_gradients.cols() == static_cast<Eigen::Index>(b.jumps.size()));
}

Model StiffSpring() {
  Model model{ImpactMsd{}};
  model.SetParameter("a", 1e12);  // impacts every half-period π/ω ≈ 3.14 µs: below zeno_interval
  return model;
}

TEST_CASE("stiff spring: constant jump intervals are not Zeno for either", "[sensitivity]") {
  const Pair p = RunBoth(StiffSpring(), SampleGrid{1e-3, 1e-5});
  CheckAgree(p, SimStop::kCompleted, 1e-12);
  const double half_period = std::numbers::pi / std::sqrt(1e12 - 0.1 * 0.1 / 4.0);
  CHECK(p.plain.jumps.size() == 318);  // ⌊(1e-3 − t_1)/(π/ω)⌋ + 1, t_1 a quarter period
  CHECK(p.sens.trajectory.jumps.back().t - p.sens.trajectory.jumps.front().t ==
        Approx(317 * half_period).epsilon(1e-6));
}

TEST_CASE("stiff spring: both stop at the jump budget, not as Zeno", "[sensitivity]") {
  SimOptions sim;
  sim.max_jumps = 200;
  const Pair p = RunBoth(StiffSpring(), SampleGrid{20.0, 5e-4}, sim);
  CheckAgree(p, SimStop::kJumpBudget, 1e-12);
  CHECK(p.plain.jumps.size() == 200);
}

TEST_CASE("bouncing ball: both stop as Zeno at the same accumulation estimate", "[sensitivity]") {
  const Model model{BouncingBall{}};
  const double g = 9.81, lambda = 0.8, h0 = 1.0;
  const double tz = std::sqrt(2 * h0 / g) + 2 * lambda * std::sqrt(2 * g * h0) / (g * (1 - lambda));
  const Pair p = RunBoth(model, SampleGrid{10.0, 1e-3});
  // The last bounces peak near atol (g·Δ²/8 ≈ 1e-10 m at Δ = 8 µs), and the sensitivity run's steps
  // differ (S is in its error test): the late jump times agree to a few 1e-7 s.
  CheckAgree(p, SimStop::kZeno, 1e-6);
  CHECK(std::abs(p.plain.status.zeno_time - tz) <= 1e-6);
  CHECK(std::abs(p.sens.trajectory.status.zeno_time - tz) <= 2e-6);
  CHECK(std::abs(p.sens.trajectory.status.zeno_time - p.plain.status.zeno_time) <= 1e-6);
  CHECK(p.sens.trajectory.status.t_reached <= tz);
}

TEST_CASE("a jump map that keeps the state in D: both stop as Zeno at that instant", "[sensitivity]") {
  Model model{BouncingBall{}};
  model.SetParameter("lambda", 0.0);  // ξ+ = (0, 0) lies in D again
  SimOptions sim;
  sim.max_jumps_at_one_time = 5;
  const Pair p = RunBoth(model, SampleGrid{2.0, 1e-3}, sim);
  CheckAgree(p, SimStop::kZeno, 1e-12);
  CHECK(p.plain.jumps.size() == 5);
  CHECK(p.sens.trajectory.status.zeno_time == p.sens.trajectory.jumps.front().t);
}

TEST_CASE("without sensitivities the states are Simulate's, bit for bit", "[sensitivity]") {
  const std::vector<std::pair<Model, SampleGrid>> cases{{Model{ImpactMsd{}}, SampleGrid{20.0, 5e-4}},
                                                        {Model{BouncingBall{}}, SampleGrid{10.0, 1e-3}},
                                                        {StiffSpring(), SampleGrid{1e-3, 1e-5}}};
  for (const auto& [model, grid] : cases) {
    const Vec x0 = DefaultState(model);
    const Trajectory a = Simulate(model, x0, grid);
    const SensitivityTrajectory b = SimulateSensitivities(model, HybridParameters::Of(model, x0),
                                                          Unknowns::Of(model), grid, {.sim = {}, .sensitivities = false});
    CHECK(a.x == b.trajectory.x);
    CHECK(a.j == b.trajectory.j);
    CHECK(a.status.message == b.trajectory.status.message);
    CHECK(b.sensitivities.size() == 0);
  }
}

}  // namespace
}  // namespace hysid
