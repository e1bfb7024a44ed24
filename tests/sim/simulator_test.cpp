// Simulator against closed forms: the §5 impact mass-spring-damper (exact jump times and states)
// and the bouncing ball's Zeno time.
#include <catch2/catch.hpp>

#include <atomic>
#include <cmath>
#include <numbers>

#include "core/builtin/bouncing_ball.hpp"
#include "core/builtin/impact_msd.hpp"
#include "core/builtin/impact_pendulum.hpp"
#include "sim/simulator.hpp"

namespace hysid {
namespace {

// Closed-form impact-msd: between jumps x(s) = e^{−bs/2}(A cos ω s + B sin ω s), s = t − t_j.
struct MsdClosedForm {
  double a, b, lambda;
  double omega() const { return std::sqrt(a - b * b / 4.0); }
  // State at time s after a (re)start from (x0, v0).
  Vec At(double x0, double v0, double s) const {
    const double w = omega(), d = b / 2.0;
    const double A = x0, B = (v0 + d * x0) / w;
    const double e = std::exp(-d * s), c = std::cos(w * s), sn = std::sin(w * s);
    Vec x(2);
    x[0] = e * (A * c + B * sn);
    x[1] = e * (-d * (A * c + B * sn) + (-A * w * sn + B * w * c));
    return x;
  }
};

TEST_CASE("an even grid of count samples ends at or before t_end with count samples", "[sim]") {
  // 45·(3.700000000000001/45) rounds to 3.7000000000000015: the plain step would pass t_end.
  const SampleGrid rounded = EvenGrid(3.700000000000001, 46);
  CHECK(rounded.size() == 46);
  CHECK(45.0 * rounded.dt <= 3.700000000000001);
  CHECK(rounded.dt == Approx(3.700000000000001 / 45.0).epsilon(1e-15));
  for (long count = 2; count < 400; count += 7) {
    for (double t_end : {0.1, 1.0, 3.700000000000001, 6.3 - 2.6, 10.0 - 6.3, 1234.5678}) {
      const SampleGrid g = EvenGrid(t_end, count);
      CHECK(g.size() == count);
      CHECK(static_cast<double>(count - 1) * g.dt <= t_end);
      CHECK(static_cast<double>(count - 1) * g.dt >= t_end * (1.0 - 1e-14));
    }
  }
}

TEST_CASE("impact-msd: 14 jumps at the closed-form times, states on the closed form", "[sim]") {
  const Model model{ImpactMsd{}};
  const SampleGrid grid{20.0, 5e-4};
  const Trajectory traj = Simulate(model, DefaultState(model), grid);
  REQUIRE(traj.status.completed());
  REQUIRE(traj.size() == 40001);
  REQUIRE(traj.jumps.size() == 14);

  const MsdClosedForm cf{5.0, 0.1, 0.99};
  const double w = cf.omega();
  const double t1 = (std::numbers::pi - std::atan(20.0 * w)) / w;
  double max_time_error = 0.0;
  for (std::size_t i = 0; i < traj.jumps.size(); ++i) {
    const double expected = t1 + static_cast<double>(i) * std::numbers::pi / w;
    max_time_error = std::max(max_time_error, std::abs(traj.jumps[i].t - expected));
    CHECK(traj.jumps[i].j == static_cast<int>(i) + 1);
    CHECK(traj.jumps[i].pre[0] == 0.0);  // put exactly on the guard
    CHECK(traj.jumps[i].post[1] == Approx(-0.99 * traj.jumps[i].pre[1]).epsilon(1e-15));
  }
  INFO("max jump-time error " << max_time_error);
  CHECK(max_time_error <= 1e-10);

  // Sampled states: piecewise closed form restarted from the closed-form post-jump state.
  double max_state_error = 0.0;
  double start_t = 0.0, sx = 20.0, sv = 0.0;
  int jump = 0;
  for (long k = 0; k < traj.size(); ++k) {
    const double t = traj.t[k];
    while (jump < 14 && t >= t1 + jump * std::numbers::pi / w) {
      const double tj = t1 + jump * std::numbers::pi / w;
      const Vec pre = cf.At(sx, sv, tj - start_t);
      start_t = tj;
      sx = 0.0;
      sv = -0.99 * pre[1];
      ++jump;
    }
    CHECK(traj.j[k] == jump);
    const Vec exact = cf.At(sx, sv, t - start_t);
    max_state_error = std::max(max_state_error, (traj.x.col(k) - exact).cwiseAbs().maxCoeff());
  }
  INFO("max state error " << max_state_error);
  CHECK(max_state_error <= 1e-8);
}

TEST_CASE("bouncing ball stops with Zeno status near the analytic accumulation time", "[sim]") {
  const Model model{BouncingBall{}};
  const double g = 9.81, lambda = 0.8, h0 = 1.0;
  const double tz = std::sqrt(2 * h0 / g) + 2 * lambda * std::sqrt(2 * g * h0) / (g * (1 - lambda));
  REQUIRE(tz == Approx(4.0637127688715781).epsilon(1e-15));
  const Trajectory traj = Simulate(model, DefaultState(model), SampleGrid{10.0, 1e-3});
  REQUIRE(traj.status.stop == SimStop::kZeno);
  CHECK(std::abs(traj.status.zeno_time - tz) <= 1e-6);
  CHECK(traj.status.t_reached <= tz);
  // Never falls through the floor.
  CHECK(traj.x.row(0).minCoeff() >= -1e-9);
  // The samples stop before the accumulation time.
  CHECK(traj.t.back() <= tz);
}

TEST_CASE("a stiff spring's constant jump intervals are not Zeno", "[sim]") {
  // a = 1e12: impacts every half-period π/ω ≈ 3.14 µs, below zeno_interval, constant up to rounding.
  // Not an accumulation: the run goes on until the jump budget, with the intervals' closed form.
  Model model{ImpactMsd{}};
  model.SetParameter("a", 1e12);
  SimOptions options;
  options.max_jumps = 200;
  const Trajectory traj = Simulate(model, DefaultState(model), SampleGrid{20.0, 5e-4}, options);
  CHECK(traj.status.stop == SimStop::kJumpBudget);
  REQUIRE(traj.jumps.size() == 200);
  const double half_period = std::numbers::pi / std::sqrt(1e12 - 0.1 * 0.1 / 4.0);
  for (std::size_t i = 1; i < traj.jumps.size(); ++i) {
    CHECK(traj.jumps[i].t - traj.jumps[i - 1].t == Approx(half_period).epsilon(1e-6));
  }
}

TEST_CASE("either raised flag, stop or cancel, stops a run before its next step", "[sim]") {
  const Model model{ImpactMsd{}};
  const SampleGrid grid{20.0, 5e-4};
  const Trajectory full = Simulate(model, DefaultState(model), grid, SimOptions{});
  REQUIRE(full.status.stop == SimStop::kCompleted);
  std::atomic<bool> lowered{false}, raised{true};
  for (const bool by_cancel : {false, true}) {
    SimOptions options;
    (by_cancel ? options.cancel : options.stop) = &lowered;
    const Trajectory same = Simulate(model, DefaultState(model), grid, options);
    CHECK(same.status.stop == SimStop::kCompleted);
    CHECK(same.t.size() == full.t.size());
    (by_cancel ? options.cancel : options.stop) = &raised;
    const Trajectory stopped = Simulate(model, DefaultState(model), grid, options);
    CHECK(stopped.status.stop == SimStop::kSolverFailure);
    CHECK_THAT(stopped.status.message, Catch::Contains("stopped at t = 0"));
    CHECK(stopped.t.size() <= 1);
  }
}

TEST_CASE("jump budget stops a run with its own status", "[sim]") {
  const Model model{ImpactMsd{}};
  SimOptions options;
  options.max_jumps = 3;
  const Trajectory traj = Simulate(model, DefaultState(model), SampleGrid{20.0, 5e-4}, options);
  CHECK(traj.status.stop == SimStop::kJumpBudget);
  CHECK(traj.jumps.size() == 3);
  CHECK(traj.t.back() <= traj.status.t_reached);
}

TEST_CASE("impact pendulum conserves energy without damping", "[sim]") {
  Model model{ImpactPendulum{}};
  model.SetParameter("b", 0.0);
  model.SetParameter("lambda", 1.0);
  const Trajectory traj = Simulate(model, DefaultState(model), SampleGrid{10.0, 1e-3});
  REQUIRE(traj.status.completed());
  REQUIRE(traj.jumps.size() >= 4);
  const double a = 9.81;
  auto energy = [&](const Eigen::Ref<const Vec>& x) { return 0.5 * x[1] * x[1] - a * std::cos(x[0]); };
  const double e0 = energy(traj.x.col(0));
  double max_drift = 0.0;
  for (long k = 0; k < traj.size(); ++k)
    max_drift = std::max(max_drift, std::abs(energy(traj.x.col(k)) - e0));
  CHECK(max_drift <= 1e-8);
  CHECK(traj.x.row(0).minCoeff() >= -1e-9);  // the wall holds
}

TEST_CASE("bad grid, options and initial state are rejected with the field named", "[sim]") {
  const Model model{ImpactMsd{}};
  const Vec x0 = DefaultState(model);
  CHECK_THROWS_WITH(Simulate(model, x0, SampleGrid{20.0, 0.0}), Catch::Contains("dt"));
  CHECK_THROWS_WITH(Simulate(model, x0, SampleGrid{-1.0, 1e-3}), Catch::Contains("t_end"));
  SimOptions bad;
  bad.rtol = -1.0;
  CHECK_THROWS_WITH(Simulate(model, x0, SampleGrid{}, bad), Catch::Contains("rtol"));
  CHECK_THROWS(Simulate(model, Vec::Zero(3), SampleGrid{}));
  Vec nan_x0 = x0;
  nan_x0[1] = std::nan("");
  CHECK_THROWS(Simulate(model, nan_x0, SampleGrid{}));
}

}  // namespace
}  // namespace hysid
