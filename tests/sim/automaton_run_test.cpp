// The run loop on hybrid automata: each guard applies its own map, modes switch the flow, a guard
// fires only where it is armed, simultaneous crossings follow the first-listed map, and the Zeno rule
// looks at one guard's jumps at a time. Closed forms: piecewise parabolas for the ball, the √h
// dynamics of the pump tank (off: √h falls at a/2; on: t = (2/a²)(P ln(u₀/u₁) + u₁ − u₀), u = P − a√h).
#include <cmath>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "sim/simulator.hpp"
#include "tests/sim/automaton_models.hpp"

namespace hysid {
namespace {

using testing::FloorCeiling;
using testing::Map;
using testing::Of;
using testing::PumpTank;

struct Event {
  double t, v_post;
  int map;
};

// The floor/ceiling ball's impacts up to t_end by its parabolas.
std::vector<Event> BallEvents(const FloorCeiling& m, double g, double h, double v, double t_end) {
  std::vector<Event> out;
  double t = 0.0;
  for (;;) {
    const double apex = h + v * v / (2 * g);
    double tau;
    int map;
    if (v > 0 && apex > m.ceiling) {
      tau = (v - std::sqrt(v * v - 2 * g * (m.ceiling - h))) / g;
      map = 1;
    } else {
      tau = (v + std::sqrt(v * v + 2 * g * h)) / g;
      map = 0;
    }
    if (t + tau > t_end) return out;
    t += tau;
    const double v_hit = v - g * tau;
    v = -(map == 0 ? m.e_floor : m.e_ceiling) * v_hit;
    h = map == 0 ? 0.0 : m.ceiling;
    out.push_back({t, v, map});
  }
}

TEST_CASE("floor/ceiling ball: each wall applies its own restitution (closed form)") {
  const FloorCeiling m;
  const Model model{m};
  const SampleGrid grid{.t_end = 3.0, .dt = 1e-2};
  const Trajectory tr = Simulate(model, Of({0.5, 4.0}), grid);
  REQUIRE(tr.status.completed());
  CHECK(tr.q.empty());  // one mode: no mode column
  const std::vector<Event> expected = BallEvents(m, 9.81, 0.5, 4.0, 3.0);
  REQUIRE(expected.size() >= 4);
  REQUIRE(expected[0].map == 1);  // the ceiling first, then the floor
  REQUIRE(tr.jumps.size() == expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    INFO("jump " << i);
    CHECK(tr.jumps[i].t == Approx(expected[i].t).margin(1e-9));
    CHECK(tr.jumps[i].post(1) == Approx(expected[i].v_post).margin(1e-9));
    CHECK(tr.jumps[i].map == expected[i].map);
    CHECK(tr.jumps[i].guard == expected[i].map);
    CHECK(tr.jumps[i].post(0) == tr.jumps[i].pre(0));
    CHECK(tr.jumps[i].mode == 0);
  }
}

// The pump tank's switch times from h0 in mode q0, by the closed form.
std::vector<double> PumpSwitches(double a, double P, double lo, double hi, double h0, int q0, double t_end,
                                 std::vector<int>* modes) {
  std::vector<double> out;
  double t = 0.0, y = std::sqrt(h0);
  int q = q0;
  for (;;) {
    double tau;
    if (q == 0) {
      tau = 2 * (y - std::sqrt(lo)) / a;
      y = std::sqrt(lo);
    } else {
      const double u0 = P - a * y, u1 = P - a * std::sqrt(hi);
      tau = 2 / (a * a) * (P * std::log(u0 / u1) + u1 - u0);
      y = std::sqrt(hi);
    }
    if (t + tau > t_end) return out;
    t += tau;
    q = 1 - q;
    out.push_back(t);
    modes->push_back(q);
  }
}

TEST_CASE("pump tank: switch times, modes and the state between them (closed form)") {
  const Model model{PumpTank{}};
  const SampleGrid grid{.t_end = 20.0, .dt = 1e-2};
  const Trajectory tr = Simulate(model, Of({1.5}), grid);
  REQUIRE(tr.status.completed());
  std::vector<int> modes;
  const std::vector<double> expected = PumpSwitches(0.5, 1.0, 1.0, 2.0, 1.5, 1, 20.0, &modes);
  REQUIRE(expected.size() >= 6);
  REQUIRE(tr.jumps.size() == expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    INFO("switch " << i);
    CHECK(tr.jumps[i].t == Approx(expected[i]).margin(1e-9));
    CHECK(tr.jumps[i].mode == modes[i]);
    CHECK(tr.jumps[i].map == (modes[i] == 1 ? 0 : 1));  // pump-on enters on, pump-off enters off
    CHECK(tr.jumps[i].post(0) == tr.jumps[i].pre(0));    // identity maps
  }
  // q per sample: the mode of the segment the sample lies on; h(t_k) in the off segments (√h linear).
  REQUIRE(tr.q.size() == tr.t.size());
  for (long k = 0; k < tr.size(); ++k) {
    const double t = tr.t[std::size_t(k)];
    std::size_t seg = 0;
    while (seg < expected.size() && expected[seg] <= t) ++seg;
    const int q = seg == 0 ? 1 : modes[seg - 1];
    INFO("sample " << k << " t = " << t);
    CHECK(tr.q[std::size_t(k)] == q);
    if (q == 0) {
      const double y = std::sqrt(2.0) - 0.25 * (t - expected[seg - 1]);
      CHECK(tr.x(0, k) == Approx(y * y).margin(1e-9));
    }
  }
}

TEST_CASE("pump tank: the initial mode from the Exogenous, checked") {
  const Model model{PumpTank{}};
  const SampleGrid grid{.t_end = 5.0, .dt = 1e-2};
  Exogenous exo;
  exo.initial_mode = 0;
  const Trajectory tr = Simulate(model, Of({1.5}), grid, {}, exo);
  REQUIRE(tr.status.completed());
  std::vector<int> modes;
  const std::vector<double> expected = PumpSwitches(0.5, 1.0, 1.0, 2.0, 1.5, 0, 5.0, &modes);
  REQUIRE(tr.jumps.size() == expected.size());
  CHECK(tr.jumps[0].t == Approx(expected[0]).margin(1e-9));
  CHECK(tr.q[0] == 0);
  exo.initial_mode = 2;  // the model has modes 0 and 1
  CHECK_THROWS_AS(Simulate(model, Of({1.5}), grid, {}, exo), std::invalid_argument);
}

// A ball falling onto one surface that two guards watch (both h, falling): guard 0 "b" and guard 1 "a".
struct TwoGuardsOneSurface : FloorCeiling {
  bool modes = false;
  ModelSpec Spec() const {
    ModelSpec s = FloorCeiling::Spec();
    s.guards = {Guard{"b", Crossing::kFalling}, Guard{"a", Crossing::kFalling}};
    s.beta = {testing::Param("one_f", 1.0, true), testing::Param("e", 0.5)};
    if (modes) {  // mode 0: "a" switches to mode 1 (identity); mode 1: "b" bounces back to mode 0
      s.modes = {"falling", "armed"};
      s.jumps = {Map("switch", 1, 0, 1, 0, 0), Map("bounce", 0, 1, 0, 0, 2)};
    } else {  // one mode: "a"'s map is listed first
      s.jumps = {Map("first", 1, -1, -1, 0, 2), Map("second", 0, -1, -1, 0, 0)};
    }
    return s;
  }
  void Psi(ConstVecRef x, const Context&, MatRef psi) const {
    psi.setZero();
    psi(0, 0) = x(0);
    psi(1, 1) = -x(1);
  }
  void Guards(ConstVecRef x, const Context&, VecRef h) const { h.setConstant(x(0)); }
  void ProjectOntoGuard(int, const Context&, VecRef x) const { x(0) = 0.0; }
};

TEST_CASE("simultaneous crossings: the first-listed map fires, the others are re-checked after it") {
  const SampleGrid grid{.t_end = 0.8, .dt = 1e-2};  // the next impact is at 2·t1 = 0.903 s
  const double t1 = std::sqrt(2.0 / 9.81);             // from rest at h = 1
  SECTION("the first map bounces: the second guard is at zero moving away and does not fire") {
    const Model model{TwoGuardsOneSurface{}};
    const Trajectory tr = Simulate(model, Of({1.0, 0.0}), grid);
    REQUIRE(tr.status.completed());
    REQUIRE(tr.jumps.size() == 1);
    CHECK(tr.jumps[0].map == 0);
    CHECK(tr.jumps[0].guard == 1);
    CHECK(tr.jumps[0].t == Approx(t1).margin(1e-9));
    CHECK(tr.jumps[0].post(1) == Approx(0.5 * 9.81 * t1).margin(1e-9));
  }
  SECTION("a mode switch first: the guard armed in the new mode fires at the same instant") {
    TwoGuardsOneSurface m;
    m.modes = true;
    const Trajectory tr = Simulate(Model{m}, Of({1.0, 0.0}), grid);
    REQUIRE(tr.status.completed());
    REQUIRE(tr.jumps.size() == 2);
    CHECK(tr.jumps[0].map == 0);
    CHECK(tr.jumps[0].mode == 1);
    CHECK(tr.jumps[1].map == 1);
    CHECK(tr.jumps[1].mode == 0);
    CHECK(tr.jumps[1].t == tr.jumps[0].t);
    CHECK(tr.jumps[1].post(1) == Approx(0.5 * 9.81 * t1).margin(1e-9));
    REQUIRE(tr.q.size() == tr.t.size());
    CHECK(tr.q.back() == 0);
  }
  SECTION("an identity map that leaves its own guard crossing chains until max_jumps_at_one_time") {
    struct Loop : TwoGuardsOneSurface {
      ModelSpec Spec() const {
        ModelSpec s = TwoGuardsOneSurface::Spec();
        s.jumps = {Map("stay", 1, -1, -1, 0, 0), Map("bounce", 0, -1, -1, 0, 2)};
        return s;
      }
    };
    SimOptions options;
    options.max_jumps_at_one_time = 7;
    const Trajectory tr = Simulate(Model{Loop{}}, Of({1.0, 0.0}), grid, options);
    CHECK(tr.status.stop == SimStop::kZeno);
    CHECK(tr.jumps.size() == 7);
    CHECK(tr.status.zeno_time == Approx(t1).margin(1e-9));
  }
}

TEST_CASE("Zeno per guard: a floor's bounces accumulate, alternating switches do not") {
  SECTION("the floor's intervals shrink geometrically: Zeno at the closed-form accumulation time") {
    FloorCeiling m;
    m.ceiling = 100.0;  // never reached
    m.e_floor = 0.5;
    const Trajectory tr = Simulate(Model{m}, Of({1.0, 0.0}), SampleGrid{.t_end = 5.0, .dt = 1e-2});
    REQUIRE(tr.status.stop == SimStop::kZeno);
    const double g = 9.81, t1 = std::sqrt(2.0 / g), v1 = g * t1;
    CHECK(tr.status.zeno_time == Approx(t1 + 2 * v1 * 0.5 / (g * 0.5)).margin(1e-6));
    CHECK(tr.status.message.find("guard 'floor'") != std::string::npos);
  }
  SECTION("pump switches alternate long and short: per guard their intervals are constant") {
    // Over all jumps, each off interval (1.66 s) is shorter than the on interval before it: with
    // zeno_window = 1 and a large zeno_interval that alone would be an accumulation.
    SimOptions options;
    options.zeno_window = 1;
    options.zeno_interval = 100.0;
    const Trajectory tr = Simulate(Model{PumpTank{}}, Of({1.5}), SampleGrid{.t_end = 30.0, .dt = 1e-2}, options);
    CHECK(tr.status.completed());
    std::vector<int> modes;
    CHECK(tr.jumps.size() == PumpSwitches(0.5, 1.0, 1.0, 2.0, 1.5, 1, 30.0, &modes).size());
  }
}

}  // namespace
}  // namespace hysid
