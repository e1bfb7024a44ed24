// The automaton examples (examples/floor-ceiling, pump-tank, heater) loaded as the programs load them
// and simulated with their defaults: the events, their maps and the modes against closed forms, at
// least 8 events, each at least 50 samples from the next.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "core/model/automaton.hpp"
#include "sim/model_check/model_check.hpp"
#include "sim/simulator.hpp"

namespace hysid {
namespace {

struct Event {
  double t;
  int map;
  double post = 0.0;  // the post-jump value of the checked state component
};

Trajectory RunDefaults(const Model& model) {
  const ModelSpec& s = model.spec();
  const Vec x0 = Eigen::Map<const Vec>(s.default_x0.data(), model.state_size());
  const Trajectory tr = Simulate(model, x0, SampleGrid{.t_end = s.default_t_end, .dt = s.default_dt});
  REQUIRE(tr.status.completed());
  return tr;
}

void CheckEvents(const Trajectory& tr, const std::vector<Event>& expected, int component, double dt) {
  REQUIRE(expected.size() >= 8);
  REQUIRE(tr.jumps.size() == expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    INFO("event " << i);
    CHECK(tr.jumps[i].t == Approx(expected[i].t).margin(1e-8));
    CHECK(tr.jumps[i].map == expected[i].map);
    CHECK(tr.jumps[i].post(component) == Approx(expected[i].post).margin(1e-8));
    if (i > 0) CHECK(expected[i].t - expected[i - 1].t >= 50 * dt);
  }
}

std::string Example(const char* name) { return std::string(HYSID_EXAMPLES_DIR) + "/" + name + "/model.toml"; }

TEST_CASE("floor-ceiling: the default run's impacts and maps equal the ballistic closed form", "[examples]") {
  const Model model = LoadModelFile(Example("floor-ceiling"));
  const Trajectory tr = RunDefaults(model);
  const double g = 9.81, e[2] = {0.9, 0.7}, top = 2.0, t_end = model.spec().default_t_end;
  double t = 0.0, h = model.spec().default_x0[0], v = model.spec().default_x0[1];
  std::vector<Event> expected;
  while (true) {
    const bool ceiling = v > 0 && v * v > 2 * g * (top - h);
    const double tau = ceiling ? (v - std::sqrt(v * v - 2 * g * (top - h))) / g : (v + std::sqrt(v * v + 2 * g * h)) / g;
    if (t + tau > t_end) break;
    t += tau;
    v = -e[ceiling ? 1 : 0] * (v - g * tau);
    h = ceiling ? top : 0.0;
    expected.push_back({t, ceiling ? 1 : 0, v});
  }
  CheckEvents(tr, expected, 1, model.spec().default_dt);
  int ceilings = 0;
  for (const Event& ev : expected) ceilings += ev.map;
  CHECK((ceilings >= 3 && ceilings <= int(expected.size()) - 3));  // both maps, several times each
}

// The time the pump tank's level takes from s1 = √h1 to s2 = √h2 in a mode with inflow P
// (h' = P − a√h): 2(s1 − s2)/a + 2P/a² ln((P − a s1)/(P − a s2)); with P = 0, 2(s1 − s2)/a.
double TankTime(double a, double p, double h1, double h2) {
  const double s1 = std::sqrt(h1), s2 = std::sqrt(h2);
  return 2 * (s1 - s2) / a + (p == 0.0 ? 0.0 : 2 * p / (a * a) * std::log((p - a * s1) / (p - a * s2)));
}

TEST_CASE("pump-tank: the default run's switches equal the closed form, the state continuous", "[examples]") {
  const Model model = LoadModelFile(Example("pump-tank"));
  const ModelSpec& s = model.spec();
  const Trajectory tr = RunDefaults(model);
  const double a = 0.5, p = 1.0, lo = 1.0, hi = 2.0;
  std::vector<Event> expected;
  double t = 0.0, h = s.default_x0[0];
  for (int mode = s.default_mode;;) {  // on: rise to h_hi, map pump-off (1); off: fall to h_lo, pump-on (0)
    const double target = mode == 1 ? hi : lo;
    t += TankTime(a, mode == 1 ? p : 0.0, h, target);
    if (t > s.default_t_end) break;
    h = target;
    expected.push_back({t, mode == 1 ? 1 : 0, target});
    mode = 1 - mode;
  }
  CheckEvents(tr, expected, 0, s.default_dt);
  for (const JumpRecord& jr : tr.jumps) {
    CHECK(jr.post(0) == jr.pre(0));  // a switch, not a jump
    CHECK(jr.mode == ModeAfter(s, 1 - jr.mode, jr.map));
  }
}

TEST_CASE("heater: three modes in their cycle off, high, low at the closed-form times", "[examples]") {
  const Model model = LoadModelFile(Example("heater"));
  const ModelSpec& s = model.spec();
  const Trajectory tr = RunDefaults(model);
  const double k = 0.1, equilibrium[3] = {0.0, 30.0, 60.0};  // T' = −k(T − E_q), E_q = P_q/k
  const int next_mode[3] = {2, 0, 1}, map_of[3] = {0, 2, 1};  // off → high → low → off
  const double threshold[3] = {18.0, 22.0, 21.0};           // the guard that leaves each mode
  std::vector<Event> expected;
  std::vector<int> modes;
  double t = 0.0, temp = s.default_x0[0];
  for (int q = s.default_mode;;) {
    t += std::log((temp - equilibrium[q]) / (threshold[q] - equilibrium[q])) / k;
    if (t > s.default_t_end) break;
    temp = threshold[q];
    expected.push_back({t, map_of[q], temp});
    q = next_mode[q];
    modes.push_back(q);
  }
  CheckEvents(tr, expected, 0, s.default_dt);
  for (std::size_t i = 0; i < tr.jumps.size(); ++i) CHECK(tr.jumps[i].mode == modes[i]);
  // The sampled mode column follows: mode off before the first switch, the last mode at the end.
  REQUIRE(tr.q.size() == std::size_t(tr.size()));
  CHECK(tr.q.front() == 0);
  CHECK(tr.q.back() == modes.back());
}

}  // namespace
}  // namespace hysid
