// The run loop with an Exogenous: a measured input u(t) drives the flow (checked against the closed
// form of the integral of a piecewise-linear u, which the stop at each input sample makes exact to
// the tolerance), and the guard parameters γ of the run (not the model's own) place the guard.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

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
