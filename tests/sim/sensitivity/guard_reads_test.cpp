// Sensitivities at crossings of guards that read more than the state: flow parameters α by name, an
// input u(t) alone, a reset that reads an input, and the cascaded tanks' overflow (tests/data/cascaded_tanks_overflow.toml), whose
// end is a guard in u, α and a guard parameter. Every column of S against central differences of
// whole simulated trajectories, ∂t_j/∂θ against the differences of the jump times, and the jump-time
// gradients against closed forms where there is one.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>

#include "core/model_file/model_file.hpp"
#include "sim/input_signal.hpp"
#include "sim/sensitivity/sensitivity.hpp"

namespace hysid {
namespace {

Vec DefaultX0(const Model& m) {
  const auto& v = m.spec().default_x0;
  return Eigen::Map<const Vec>(v.data(), static_cast<Eigen::Index>(v.size()));
}

// u(t) sampled every `dt` over [0, t_end].
InputSignal Sampled(double (*u)(double), double t_end, double dt) {
  InputSignal s;
  const auto count = static_cast<long>(std::ceil(t_end / dt)) + 1;
  s.values.resize(1, count);
  for (long k = 0; k < count; ++k) {
    s.times.push_back(static_cast<double>(k) * dt);
    s.values(0, k) = u(s.times.back());
  }
  return s;
}

// The slope of the interpolated (piecewise linear) input at t: what the run's u(t) has there.
double SlopeAt(const InputSignal& s, double t) {
  const auto hi = std::upper_bound(s.times.begin(), s.times.end(), t) - s.times.begin();
  REQUIRE(hi > 0);
  REQUIRE(hi < static_cast<long>(s.times.size()));
  const auto k = static_cast<std::size_t>(hi);
  return (s.values(0, hi) - s.values(0, hi - 1)) / (s.times[k] - s.times[k - 1]);
}

struct Agreement {
  double states = 0.0, jump_times = 0.0;
  SensitivityTrajectory nominal;
};

// Largest |S_k − central difference| over every column, relative to the column's largest |S|, over
// samples whose segment agrees in the ± runs; and the jump times' gradients, relative to the largest
// |∂t_j/∂θ_i| (or 1 when that is below 1). Steps `step`·max(1, |θ_i|).
Agreement CompareWithDifferences(const Model& model, const SampleGrid& grid, const InputSignal* inputs,
                                 double step = 1e-5) {
  const Unknowns u = Unknowns::Of(model);
  const HybridParameters nominal = HybridParameters::Of(model, DefaultX0(model));
  SensitivityOptions states_only;
  states_only.sensitivities = false;
  auto run = [&](const HybridParameters& p, const SensitivityOptions& o) {
    return SimulateSensitivities(model, p, u, grid, o, inputs);
  };
  Agreement worst{.nominal = run(nominal, {})};
  const SensitivityTrajectory& s = worst.nominal;
  REQUIRE(s.ok());
  const Vec theta = nominal.Theta(u);
  REQUIRE(theta.size() == s.parameters);
  for (Eigen::Index i = 0; i < theta.size(); ++i) {
    const double h = step * std::max(1.0, std::abs(theta[i]));
    Vec tp = theta, tm = theta;
    tp[i] += h;
    tm[i] -= h;
    const SensitivityTrajectory plus = run(nominal.WithTheta(u, tp), states_only);
    const SensitivityTrajectory minus = run(nominal.WithTheta(u, tm), states_only);
    REQUIRE(plus.ok());
    REQUIRE(minus.ok());
    double err = 0.0, scale = 0.0;
    long compared = 0;
    for (long k = 0; k < s.trajectory.size(); ++k) {
      const auto ku = static_cast<std::size_t>(k);
      scale = std::max(scale, s.S(k).col(i).cwiseAbs().maxCoeff());
      if (plus.trajectory.j[ku] != s.trajectory.j[ku] || minus.trajectory.j[ku] != s.trajectory.j[ku]) continue;
      const Vec fd = (plus.trajectory.x.col(k) - minus.trajectory.x.col(k)) / (2 * h);
      err = std::max(err, (fd - s.S(k).col(i)).cwiseAbs().maxCoeff());
      ++compared;
    }
    CHECK(compared > s.trajectory.size() - 4 * static_cast<long>(s.trajectory.jumps.size()) - 4);
    const std::string name = u.Names(model)[static_cast<std::size_t>(i)];
    UNSCOPED_INFO("column " << i << " (" << name << "): " << err / scale);
    worst.states = std::max(worst.states, err / scale);
    REQUIRE(plus.trajectory.jumps.size() == s.trajectory.jumps.size());
    REQUIRE(minus.trajectory.jumps.size() == s.trajectory.jumps.size());
    const double jscale = std::max(1.0, s.jump_time_gradients.row(i).cwiseAbs().maxCoeff());
    for (std::size_t j = 0; j < s.trajectory.jumps.size(); ++j) {
      const double fd = (plus.trajectory.jumps[j].t - minus.trajectory.jumps[j].t) / (2 * h);
      const double e = std::abs(fd - s.jump_time_gradients(i, static_cast<Eigen::Index>(j))) / jscale;
      UNSCOPED_INFO("jump " << j << " d t/d " << name << ": " << s.jump_time_gradients(i, static_cast<Eigen::Index>(j))
                            << " differences " << fd);
      worst.jump_times = std::max(worst.jump_times, e);
    }
  }
  return worst;
}

// x' = a − b x, reset x+ = λ x when x reaches half its equilibrium: h = x − a/(2b) reads α by name.
const char* kHalfway = R"toml(name = "halfway"
states = ["x"]
alpha = [{ name = "a", value = 2.0 }, { name = "b", value = 1.0 }]
beta = [{ name = "lambda", value = 0.2 }]
[flow]
phi = [["1", "-x"]]
rows = ["x"]
[jump]
psi = [["x"]]
rows = ["x"]
[[guard]]
name = "half"
h = "x - 0.5*a/b"
direction = "rising"
[sets]
C = "x <= 0.5*a/b"
D = "x >= 0.5*a/b"
[defaults]
x0 = [0.1]
t_end = 5.0
dt = 1e-2
)toml";

TEST_CASE("a guard in α: S and the jump times match central differences and the closed form", "[sensitivity]") {
  const Model model = ParseModelFile(kHalfway, "halfway.toml").model;
  const Agreement a = CompareWithDifferences(model, SampleGrid{5.0, 1e-2}, nullptr);
  CHECK(a.states < 1e-5);
  CHECK(a.jump_times < 1e-5);
  // First crossing: x(t) = a/b − (a/b − x0) e^{−bt} = a/(2b) at t1 = ln((a − b x0)/(a/2))/b, so
  // ∂t1/∂a = (1/(a − b x0) − 1/a)/b and ∂t1/∂b = −t1/b − x0/(b(a − b x0)).
  const double A = 2.0, B = 1.0, x0 = 0.1, t1 = std::log((A - B * x0) / (A / 2)) / B;
  REQUIRE(a.nominal.trajectory.jumps.size() >= 5);
  CHECK(a.nominal.trajectory.jumps[0].t == Approx(t1).epsilon(1e-9));
  CHECK(a.nominal.jump_time_gradients(0, 0) == Approx((1 / (A - B * x0) - 1 / A) / B).epsilon(1e-6));
  CHECK(a.nominal.jump_time_gradients(1, 0) == Approx(-t1 / B - x0 / (B * (A - B * x0))).epsilon(1e-6));
}

// A tank h' = k u − c h with a pump that runs while the supply u(t) is above u_c: the switches are
// guards in the input alone, u − u_c (no state).
const char* kSupply = R"toml(name = "supply-pump"
states = ["h"]
inputs = ["u"]
modes = ["off", "on"]
alpha = [{ name = "k", value = 0.8 }, { name = "c", value = 0.5 }]
guard_params = [{ name = "u_c", value = 1.3 }]
[[flow]]
mode = "off"
phi = [[0, "-h"]]
[[flow]]
mode = "on"
phi = [["u", "-h"]]
[[guard]]
name = "drop"
h = "u - u_c"
direction = "falling"
[[guard]]
name = "rise"
h = "u - u_c"
direction = "rising"
[[jump]]
name = "stop"
guard = "drop"
from = "on"
to = "off"
[[jump]]
name = "start"
guard = "rise"
from = "off"
to = "on"
[defaults]
x0 = [0.5]
mode = "off"
t_end = 6.0
dt = 1e-2
)toml";

double Supply(double t) { return 1.0 + 0.8 * std::sin(2.0 * t); }
double SupplyRate(double t) { return 1.6 * std::cos(2.0 * t); }

TEST_CASE("a guard in an input alone: switches where u crosses u_c, S matches central differences",
          "[sensitivity]") {
  const Model model = ParseModelFile(kSupply, "supply.toml").model;
  const InputSignal u = Sampled(Supply, 6.0, 1e-3);
  const Agreement a = CompareWithDifferences(model, SampleGrid{6.0, 1e-2}, &u, 1e-4);
  CHECK(a.states < 1e-5);
  CHECK(a.jump_times < 1e-5);
  // u = 1 + 0.8 sin 2t crosses 1.3 rising at t = asin(0.375)/2 (+ kπ) and falling at (π − asin 0.375)/2:
  // ∂t_j/∂u_c = 1/u'(t_j) (the slope of the interpolated u), and no other parameter moves a switch.
  const auto& jumps = a.nominal.trajectory.jumps;
  REQUIRE(jumps.size() == 4);
  const double s = std::asin(0.375);
  const double expected[] = {s / 2, (M_PI - s) / 2, (s + 2 * M_PI) / 2, (3 * M_PI - s) / 2};
  for (std::size_t j = 0; j < jumps.size(); ++j) {
    CHECK(jumps[j].t == Approx(expected[j]).margin(1e-5));
    const auto jj = static_cast<Eigen::Index>(j);
    CHECK(a.nominal.jump_time_gradients(2, jj) == Approx(1.0 / SlopeAt(u, jumps[j].t)).epsilon(1e-7));
    CHECK(a.nominal.jump_time_gradients(2, jj) == Approx(1.0 / SupplyRate(jumps[j].t)).epsilon(1e-3));
    CHECK(std::abs(a.nominal.jump_time_gradients(0, jj)) < 1e-12);
    CHECK(std::abs(a.nominal.jump_time_gradients(3, jj)) < 1e-12);
  }
}

// The same flow and guard, the reset reading an input: x+ = λ x + g u(t). The post-jump state moves
// with the jump time through u: S⁺ carries (∂g/∂t) ∂t_j/∂θ (here g·0.1 ∂t_j/∂θ).
const char* kKick = R"toml(name = "kick"
states = ["x"]
inputs = ["u"]
alpha = [{ name = "a", value = 2.0 }, { name = "b", value = 1.0 }]
beta = [{ name = "lambda", value = 0.2 }, { name = "g", value = 0.3 }]
[flow]
phi = [["1", "-x"]]
rows = ["x"]
[jump]
psi = [["x", "u"]]
rows = ["x"]
[[guard]]
name = "half"
h = "x - 0.5*a/b"
direction = "rising"
[sets]
C = "x <= 0.5*a/b"
D = "x >= 0.5*a/b"
[defaults]
x0 = [0.1]
t_end = 5.0
dt = 1e-2
)toml";

// A ramp: its interpolation has no kinks, so the differences of whole runs are free of the averaged
// slope where a moved jump time crosses an input sample.
double Kick(double t) { return 0.3 + 0.1 * t; }

TEST_CASE("a reset in an input: S after each jump matches central differences", "[sensitivity]") {
  const Model model = ParseModelFile(kKick, "kick.toml").model;
  const InputSignal u = Sampled(Kick, 5.0, 1e-3);
  const Agreement a = CompareWithDifferences(model, SampleGrid{5.0, 1e-2}, &u, 1e-4);
  REQUIRE(a.nominal.trajectory.jumps.size() >= 5);
  CHECK(a.states < 1e-5);
  CHECK(a.jump_times < 1e-5);
}

double Pump(double t) { return 1.0 + 0.6 * std::sin(0.4 * t); }

TEST_CASE("cascaded tanks with overflow: the overflow ends on k1 u − a1 √H, S matches central differences",
          "[sensitivity]") {
  const Model model = ReadModelFile("tests/data/cascaded_tanks_overflow.toml").model;
  // The differences of whole runs: steps 1e-4 (at 1e-5 the dense output's rounding across the input's
  // samples, divided by the step, reaches 1e-5 of S). A jump time moved across an input sample by a
  // step sees the interpolated u's slope change there, which the central difference averages: with
  // u sampled every 1e-3 that stays below 5e-5 (measured 9e-6, and 4e-6 for the states).
  const InputSignal u = Sampled(Pump, 60.0, 1e-3);
  const Agreement a = CompareWithDifferences(model, SampleGrid{60.0, 0.1}, &u, 1e-4);
  CHECK(a.states < 1e-5);
  CHECK(a.jump_times < 5e-5);
  const auto& jumps = a.nominal.trajectory.jumps;
  REQUIRE(jumps.size() >= 4);
  for (std::size_t j = 0; j < jumps.size(); ++j) {
    if (jumps[j].map != 1) continue;  // overflow-end: k1 u(t) = a1 √H, so u(t_j) = 0.4/0.5 = 0.8
    CHECK(Pump(jumps[j].t) == Approx(0.8).margin(1e-5));
    // ∂t_j/∂H = (a1/(2√H))/(k1 u'(t_j)) where the guard alone moves (h1 held at H since the start).
    // u' is the interpolated input's slope (within 1e-3 of the analytic 0.24 cos 0.4t at dt = 1e-3).
    const double rate = 0.5 * SlopeAt(u, jumps[j].t);
    CHECK(a.nominal.jump_time_gradients(3, static_cast<Eigen::Index>(j)) == Approx(0.4 / 2 / rate).epsilon(1e-7));
    CHECK(SlopeAt(u, jumps[j].t) == Approx(0.24 * std::cos(0.4 * jumps[j].t)).epsilon(1e-3));
  }
}

}  // namespace
}  // namespace hysid
