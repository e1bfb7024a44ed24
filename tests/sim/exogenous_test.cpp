// The run loop with an Exogenous: a measured input u(t) drives the flow (checked against the closed
// forms of the integral of a piecewise-linear u, with its kinks stopped at, and of an impact
// oscillator driven by a finely sampled u, whose samples CVODE steps across), and the guard
// parameters γ of the run (not the model's own) place the guard.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include <unsupported/Eigen/MatrixFunctions>

#include "core/model_file/model_file.hpp"
#include "sim/exogenous.hpp"
#include "sim/sensitivity/sensitivity.hpp"
#include "sim/simulator.hpp"

namespace hysid {
namespace {

// x' = u(t), v' = 0: x is the integral of u; a wall at x = w resets x to 0 (no jump before it).
constexpr const char* kIntegrator = R"(
name = "integrator"
states = ["x", "v"]
inputs = ["u"]
alpha = [ { name = "g", value = 1.0 } ]
beta = [ { name = "one", value = 1.0, known = true } ]
guard_params = [ { name = "w", value = 100.0 } ]
[flow]
phi = [["u"], [0]]
rows = ["x"]
[jump]
psi = [[0], ["v"]]
rows = ["x"]
[[guard]]
name = "wall"
h = "x - w"
direction = "rising"
[sets]
C = "x <= w"
D = "x >= w"
[defaults]
x0 = [0, 1]
t_end = 1
dt = 0.01
)";

// u sampled at irregular times: a zig-zag, so a step across a sample would miss its kink.
InputSignal ZigZag() {
  InputSignal s;
  s.times = {0.0, 0.13, 0.3, 0.31, 0.62, 0.8, 1.0};
  s.values.resize(1, 7);
  s.values << 0.0, 2.0, -1.0, 3.0, 0.5, 4.0, -2.0;
  return s;
}

// ∫_0^t u for the piecewise-linear u.
double Integral(const InputSignal& s, double t) {
  double sum = 0.0;
  for (std::size_t k = 0; k + 1 < s.times.size() && s.times[k] < t; ++k) {
    const double a = s.times[k], b = std::min(t, s.times[k + 1]);
    const double ua = s.values(0, static_cast<Eigen::Index>(k));
    const double slope = (s.values(0, static_cast<Eigen::Index>(k) + 1) - ua) / (s.times[k + 1] - a);
    sum += ua * (b - a) + 0.5 * slope * (b - a) * (b - a);
  }
  return sum;
}

TEST_CASE("a measured input drives the flow: x is the integral of the interpolated u", "[exogenous]") {
  const Model model = ParseModelFile(kIntegrator, "integrator.toml").model;
  const InputSignal u = ZigZag();
  const SampleGrid grid{.t_end = 1.0, .dt = 0.01};
  SimOptions options;
  options.rtol = options.atol = 1e-10;
  const Trajectory tr = Simulate(model, Vec::Zero(2).eval() + Vec::Unit(2, 1), grid, options, {.gamma = {}, .inputs = &u});
  REQUIRE(tr.status.completed());
  REQUIRE(tr.jumps.empty());
  double worst = 0.0;
  for (long k = 0; k < tr.size(); ++k) worst = std::max(worst, std::abs(tr.x(0, k) - Integral(u, tr.t[k])));
  CHECK(worst < 1e-8);
}

// The closed form of examples/driven-oscillator (x' = v, v' = −k x − b v + G u, a wall at x = 1 with
// v⁺ = −λ v) on a piecewise-linear u: on each input interval the flow is linear with
// the affine forcing G(u_k + s_k τ), so z = (x, v, 1, τ) obeys z' = A z and z(τ) = exp(Aτ) z(0); a
// crossing of x = 1 is found by bisection on that. The samples at the input times, and the jump times.
struct DrivenClosedForm {
  Mat x;
  std::vector<double> jumps;
};
DrivenClosedForm SolveDriven(const InputSignal& u, double k, double b, double g, double lambda) {
  const auto count = static_cast<Eigen::Index>(u.times.size());
  DrivenClosedForm out{Mat::Zero(2, count), {}};
  Eigen::Vector2d x(0.0, 0.0);
  for (Eigen::Index i = 0; i + 1 < count; ++i) {
    out.x.col(i) = x;
    const double t0 = u.times[static_cast<std::size_t>(i)], dt = u.times[static_cast<std::size_t>(i) + 1] - t0;
    Eigen::Matrix4d a = Eigen::Matrix4d::Zero();
    a(0, 1) = 1.0;
    a(1, 0) = -k;
    a(1, 1) = -b;
    a(1, 2) = g * u.values(0, i);
    a(1, 3) = g * (u.values(0, i + 1) - u.values(0, i)) / dt;
    a(3, 2) = 1.0;
    double tau = 0.0;
    for (;;) {
      const Eigen::Vector4d z0(x[0], x[1], 1.0, tau);
      const auto at = [&](double s) -> Eigen::Vector4d { return (a * s).exp() * z0; };
      const Eigen::Vector4d end = at(dt - tau);
      if (!(end[0] > 1.0)) {
        x = end.head<2>();
        break;
      }
      double lo = 0.0, hi = dt - tau;
      for (int it = 0; it < 80 && hi - lo > 1e-16; ++it) (at(0.5 * (lo + hi))[0] > 1.0 ? hi : lo) = 0.5 * (lo + hi);
      const Eigen::Vector4d hit = at(lo);
      out.jumps.push_back(t0 + tau + lo);
      x = Eigen::Vector2d(1.0, -lambda * hit[1]);
      tau += lo;
    }
  }
  out.x.col(count - 1) = x;
  return out;
}

TEST_CASE("a finely sampled input is stepped across, as accurately as stopping at every sample", "[exogenous]") {
  const Model model = ReadModelFile(HYSID_EXAMPLES_DIR "/driven-oscillator/driven-oscillator.toml").model;
  const SampleGrid grid{.t_end = 10.0, .dt = 1e-3};  // two impacts
  InputSignal u;
  for (long k = 0; k < grid.size(); ++k) u.times.push_back(static_cast<double>(k) * grid.dt);
  u.values.resize(1, grid.size());
  for (long k = 0; k < grid.size(); ++k) {
    const double t = u.times[static_cast<std::size_t>(k)];
    u.values(0, k) = std::sin(1.3 * t) + 0.5 * std::sin(3.7 * t);
  }
  const DrivenClosedForm exact = SolveDriven(u, 4.0, 0.2, 3.0, 0.8);
  REQUIRE(exact.jumps.size() == 2);
  REQUIRE(InputKinkTimes(u, SimOptions{}.input_kink).empty());
  SimOptions every = SimOptions{}, rule = SimOptions{};
  every.input_kink = 0.0;  // the stop at every input sample
  // The closed form's error of each run; at the fits' tolerances (1e-10 and looser) the rule steps
  // across the samples with fewer steps and a smaller error than the stop at every sample (whose
  // jump times are off by 5e-7 at every tolerance from 1e-11 to 1e-6); at 1e-12 it resolves the
  // sub-tolerance kinks with more steps, within the same bound.
  for (const double tol : {1e-12, 1e-10, 1e-8}) {
    every.rtol = every.atol = rule.rtol = rule.atol = tol;
    const Trajectory a = Simulate(model, Vec::Zero(2), grid, rule, {.gamma = {}, .inputs = &u});
    const Trajectory b = Simulate(model, Vec::Zero(2), grid, every, {.gamma = {}, .inputs = &u});
    REQUIRE(a.status.completed());
    REQUIRE(b.status.completed());
    REQUIRE(a.jumps.size() == 2);
    REQUIRE(b.jumps.size() == 2);
    const double error_rule = (a.x - exact.x).cwiseAbs().maxCoeff();
    const double error_every = (b.x - exact.x).cwiseAbs().maxCoeff();
    CAPTURE(tol, error_rule, error_every, a.stats.steps, b.stats.steps);
    for (int j = 0; j < 2; ++j) CHECK(std::abs(a.jumps[std::size_t(j)].t - exact.jumps[std::size_t(j)]) < 1e4 * tol);
    CHECK(error_rule < 1e4 * tol);
    if (tol >= 1e-10) {
      CHECK(error_rule < error_every);
      CHECK(a.stats.steps < b.stats.steps / 2);  // the samples are crossed, not stopped at
    }
  }
}

TEST_CASE("the run's guard parameters place the guard, the model's own are the default", "[exogenous]") {
  const Model model = ParseModelFile(kIntegrator, "integrator.toml").model;
  InputSignal u;  // u = 1: x = t
  u.times = {0.0, 1.0};
  u.values = Mat::Ones(1, 2);
  const SampleGrid grid{.t_end = 1.0, .dt = 0.01};
  const Vec x0 = Vec::Unit(2, 1);
  CHECK(Simulate(model, x0, grid, {}, {.gamma = {}, .inputs = &u}).jumps.empty());  // w = 100 (the model's)
  const Trajectory tr = Simulate(model, x0, grid, {}, {.gamma = Vec::Constant(1, 0.37), .inputs = &u});
  REQUIRE(tr.status.completed());
  REQUIRE(tr.jumps.size() == 2);  // at x = 0.37: t = 0.37 and 0.74
  CHECK(tr.jumps[0].t == Approx(0.37).epsilon(1e-9));
  CHECK(tr.jumps[1].t == Approx(0.74).epsilon(1e-9));
  // The sensitivities run on the same γ (HybridParameters::gamma) and the same inputs.
  HybridParameters p = HybridParameters::Of(model, x0);
  p.gamma = Vec::Constant(1, 0.37);
  const SensitivityTrajectory s = SimulateSensitivities(model, p, Unknowns::Of(model), grid, {}, &u);
  REQUIRE(s.trajectory.status.completed());
  CHECK(s.trajectory.jumps.size() == 2);
  CHECK(s.trajectory.jumps[0].t == Approx(0.37).epsilon(1e-9));
}

TEST_CASE("inputs and guard parameters that do not fit are refused by name", "[exogenous]") {
  const Model model = ParseModelFile(kIntegrator, "integrator.toml").model;
  const SampleGrid grid{.t_end = 1.0, .dt = 0.01};
  const Vec x0 = Vec::Unit(2, 1);
  using Catch::Matchers::Contains;
  CHECK_THROWS_WITH(Simulate(model, x0, grid), Contains("model 'integrator' has inputs (u) and none were given"));
  InputSignal short_u;
  short_u.times = {0.0, 0.5};
  short_u.values = Mat::Ones(1, 2);
  CHECK_THROWS_WITH(Simulate(model, x0, grid, {}, {.gamma = {}, .inputs = &short_u}), Contains("u"));
  InputSignal u;
  u.times = {0.0, 1.0};
  u.values = Mat::Ones(1, 2);
  CHECK_THROWS_WITH(Simulate(model, x0, grid, {}, {.gamma = Vec::Constant(2, 1.0), .inputs = &u}),
                    Contains("guard parameters have 2 entries; model 'integrator' has 1"));
}

}  // namespace
}  // namespace hysid
