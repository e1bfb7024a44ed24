// The recursive pass of a hybrid automaton (core/identify/events.hpp) on closed-form data: a ball
// between a floor and a ceiling with two restitutions (piecewise parabolas), a pump tank whose
// two flow modes switch at two levels without a jump (a fine RK4 of h' = −a√h + P·q), and a tank
// with both modes and a jump in the second mode (the run loop's, tests/sim/automaton_models.hpp).
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <catch2/catch.hpp>

#include "core/identify/events.hpp"
#include "core/model/automaton.hpp"
#include "sim/measurement.hpp"
#include "sim/refine/start.hpp"
#include "sim/simulator.hpp"
#include "tests/sim/automaton_models.hpp"

namespace hysid {
namespace {

using testing::Map;
using testing::Param;

constexpr double kG = 2.0, kFloor = 0.9, kCeiling = 0.7;

// A ball between a floor (h = 0) and a ceiling (h = 1): ξ = (h, v), h' = v, v' = −g; each wall has
// its own restitution (map "floor": e_floor = β1, map "ceiling": e_ceiling = β3), or with `one_map`
// the paper's class with one e = β1 for both.
testing::FloorCeiling TwoWalls() {
  testing::FloorCeiling m;
  m.g = kG;
  m.e_floor = kFloor;
  m.e_ceiling = kCeiling;
  m.x0 = {0.5, 5.0};
  return m;
}

struct Truth {
  Mat y;                      // noisy samples
  std::vector<long> samples;  // first sample after each true event
  std::vector<int> maps;      // its map
  std::vector<double> times;  // its instant
};

// The parabolas from (h, v) = (0.5, 5) until t_end, sampled every dt, noise σ on both states.
Truth WallsData(double dt, double t_end, double sigma, unsigned seed) {
  Truth out;
  double t0 = 0.0, h0 = 0.5, v0 = 5.0;
  std::vector<double> start_t = {0.0}, start_h = {0.5}, start_v = {5.0};  // each parabola's start
  while (t0 < t_end) {
    // Earliest τ > 0 with h0 + v0 τ − gτ²/2 = wall, wall 0 while falling, 1 while rising.
    auto hit = [&](double wall) -> double {
      const double disc = v0 * v0 + 2.0 * kG * (h0 - wall);
      if (disc < 0.0) return INFINITY;
      const double r1 = (v0 - std::sqrt(disc)) / kG, r2 = (v0 + std::sqrt(disc)) / kG;
      return r1 > 1e-12 ? r1 : (r2 > 1e-12 ? r2 : INFINITY);
    };
    const double tf = hit(0.0), tc = hit(1.0);
    const bool ceiling = tc < tf;
    const double tau = std::min(tf, tc);
    const double v_minus = v0 - kG * tau;
    t0 += tau;
    h0 = ceiling ? 1.0 : 0.0;
    v0 = -(ceiling ? kCeiling : kFloor) * v_minus;
    out.times.push_back(t0);
    out.maps.push_back(ceiling ? 1 : 0);
    start_t.push_back(t0);
    start_h.push_back(h0);
    start_v.push_back(v0);
  }
  const long count = static_cast<long>(std::floor(t_end / dt)) + 1;
  out.y.resize(2, count);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  std::size_t piece = 0;
  for (long k = 0; k < count; ++k) {
    const double t = static_cast<double>(k) * dt;
    while (piece + 1 < start_t.size() && start_t[piece + 1] <= t) ++piece;
    const double s = t - start_t[piece];
    out.y(0, k) = start_h[piece] + start_v[piece] * s - 0.5 * kG * s * s + noise(rng);
    out.y(1, k) = start_v[piece] - kG * s + noise(rng);
  }
  for (std::size_t i = 0; i < out.times.size();) {  // drop impacts after the last sample
    if (out.times[i] > static_cast<double>(count - 1) * dt) {
      out.times.resize(i);
      out.maps.resize(i);
      break;
    }
    out.samples.push_back(static_cast<long>(std::ceil(out.times[i] / dt)));
    ++i;
  }
  return out;
}

TEST_CASE("two walls: every impact is assigned to its wall's map and each restitution is its own") {
  const double dt = 1e-3, sigma = 1e-3;
  const Truth truth = WallsData(dt, 6.0, sigma, 7);
  REQUIRE(truth.samples.size() >= 8);
  REQUIRE(std::count(truth.maps.begin(), truth.maps.end(), 1) >= 3);
  const Model model{TwoWalls()};
  IdentifierSettings settings;
  settings.sets = false;
  const IdentifyResult r = Identify(model, truth.y, dt, settings);
  REQUIRE(r.events.size() == truth.samples.size());
  CHECK(r.events_reason.empty());
  for (std::size_t i = 0; i < r.events.size(); ++i) {
    INFO("event " << i << " at sample " << truth.samples[i]);
    CHECK(r.events[i].jump);
    CHECK(std::abs(r.events[i].sample - truth.samples[i]) <= 1);
    CHECK(r.events[i].map == truth.maps[i]);
    CHECK(r.events[i].guard == truth.maps[i]);
  }
  // Per map, the least-squares slope of v+ on −v− over that map's detected events and its standard
  // error (σ√(1 + e²) per row): the pass gives the same estimate (one β regression, ψ zero outside
  // each map's slice, so the maps do not mix), within 3 SE of the truth.
  for (int m = 0; m < 2; ++m) {
    double sxx = 0.0, sxy = 0.0;
    for (const AutomatonEvent& e : r.events) {
      if (e.map != m) continue;
      const double x = -truth.y(1, e.sample - 1), y = truth.y(1, e.sample);
      sxx += x * x;
      sxy += x * y;
    }
    const double e_true = m == 0 ? kFloor : kCeiling;
    const double se = sigma * std::sqrt(1.0 + e_true * e_true) / std::sqrt(sxx);
    INFO("map " << m << ": estimate " << r.beta_hat[2 * m + 1] << ", SE " << se);
    const Eigen::Index e_index = 2 * m + 1;  // β = (one_f, e_floor, one_c, e_ceiling)
    CHECK(r.beta_hat[e_index] == Approx(sxy / sxx).epsilon(1e-6));
    CHECK(std::abs(r.beta_hat[e_index] - e_true) < 3.0 * se);
  }
  // The one-map model on the same data averages the two walls: its e is between them and far from both.
  testing::FloorCeiling one = TwoWalls();
  one.one_map = true;
  const IdentifyResult averaged = Identify(Model{one}, truth.y, dt, settings);
  CHECK(averaged.events.empty());
  CHECK(averaged.beta_hat[1] > kCeiling + 0.02);
  CHECK(averaged.beta_hat[1] < kFloor - 0.02);
}

// The pump tank: h' = −a√h + P·q, q = 1 ("on") until h reaches h_hi, then 0 ("off") until h falls to
// h_lo; both switches are identity maps.
constexpr double kA = 0.5, kP = 1.0, kLow = 1.0, kHigh = 2.0;

struct PumpTank {
  ModelSpec Spec() const {
    ModelSpec s;
    s.name = "pump-tank";
    s.state_names = {"h"};
    s.alpha = {Param("a", kA), Param("P", kP)};
    s.flow_rows = {0};
    s.guards = {Guard{"low", Crossing::kFalling}, Guard{"high", Crossing::kRising}};
    s.default_x0 = {1.5};
    s.modes = {"off", "on"};
    s.jumps = {Map("pump-on", 0, 0, 1, 0, 0), Map("pump-off", 1, 1, 0, 0, 0)};
    return s;
  }
  void Phi(ConstVecRef x, const Context& ctx, MatRef phi) const {
    phi(0, 0) = -std::sqrt(std::max(x(0), 0.0));
    phi(0, 1) = ctx.mode == 1 ? 1.0 : 0.0;
  }
  void Psi(ConstVecRef, const Context&, MatRef) const {}
  void Guards(ConstVecRef x, const Context&, VecRef h) const {
    h(0) = x(0) - kLow;
    h(1) = x(0) - kHigh;
  }
  bool InFlowSet(ConstVecRef, const Context&) const { return true; }
  bool InJumpSet(ConstVecRef, const Context&) const { return false; }
};

double TankRate(double h, int q) { return -kA * std::sqrt(h) + kP * q; }

double Rk4(double h, int q, double step) {
  const double k1 = TankRate(h, q), k2 = TankRate(h + 0.5 * step * k1, q), k3 = TankRate(h + 0.5 * step * k2, q),
               k4 = TankRate(h + step * k3, q);
  return h + step / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
}

// RK4 at δt/200; a crossing is placed by the linear interpolation of its sub-step, integrated to it
// and continued in the new mode.
Truth TankData(int q0, double dt, double t_end, double sigma, unsigned seed, std::vector<int>* true_modes) {
  Truth out;
  const long count = static_cast<long>(std::floor(t_end / dt)) + 1;
  out.y.resize(1, count);
  true_modes->assign(std::size_t(count), 0);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  double h = 1.5;
  int q = q0;
  constexpr int kSub = 200;
  const double sub = dt / kSub;
  for (long k = 0; k < count; ++k) {
    out.y(0, k) = h + noise(rng);
    (*true_modes)[std::size_t(k)] = q;
    for (int i = 0; i < kSub; ++i) {
      double next = Rk4(h, q, sub);
      const double level = q == 1 ? kHigh : kLow;
      if ((next - level) * (h - level) <= 0.0 && next != h) {
        const double f = (level - h) / (next - h);
        h = Rk4(h, q, f * sub);
        const double t = static_cast<double>(k) * dt + (i + f) * sub;
        out.times.push_back(t);
        out.maps.push_back(q == 1 ? 1 : 0);
        out.samples.push_back(static_cast<long>(std::ceil(t / dt)));
        q = 1 - q;
        next = Rk4(h, q, (1.0 - f) * sub);
      }
      h = next;
    }
  }
  return out;
}

TEST_CASE("pump tank: switches found within one sample, the initial mode inferred, a and P estimated") {
  const double dt = 0.01, sigma = 1e-3;
  const Model model{PumpTank{}};
  REQUIRE(IsAutomaton(model.spec()));
  for (int q0 : {1, 0}) {
    std::vector<int> true_modes;
    const Truth truth = TankData(q0, dt, 20.0, sigma, 11u + unsigned(q0), &true_modes);
    REQUIRE(truth.samples.size() >= 6);
    IdentifierSettings settings;
    settings.sets = false;
    const IdentifyResult r = Identify(model, truth.y, dt, settings);
    INFO("true initial mode " << q0);
    CHECK(r.initial_mode_inferred);
    CHECK(r.initial_mode == q0);
    REQUIRE(r.events.size() == truth.samples.size());
    CHECK(r.events_reason.empty());
    for (std::size_t i = 0; i < r.events.size(); ++i) {
      INFO("switch " << i << " at t = " << truth.times[i] << ", found at t = " << r.events[i].time);
      CHECK_FALSE(r.events[i].jump);
      CHECK(std::abs(r.events[i].sample - truth.samples[i]) <= 1);
      CHECK(std::abs(r.events[i].time - truth.times[i]) <= dt);
      CHECK(r.events[i].map == truth.maps[i]);
      CHECK(r.events[i].mode_after == 1 - r.events[i].mode_before);
    }
    long wrong = 0;
    for (std::size_t k = 0; k < true_modes.size(); ++k) wrong += r.mode[k] != true_modes[k] ? 1 : 0;
    CHECK(wrong <= static_cast<long>(truth.samples.size()));  // at most one sample per switch
    CHECK(r.jumps_detected == 0);  // no jumps: gamma marks the switches only
    CHECK(std::count(r.gamma.begin(), r.gamma.end(), 1) == static_cast<long>(r.events.size()));
    // The flow regression with each sample's mode: α within a few of its standard errors (about
    // 3e-3 for a and 4e-3 for P at σ = 1e-3 over 2000 samples).
    CHECK(r.alpha_hat[0] == Approx(kA).margin(0.015));
    CHECK(r.alpha_hat[1] == Approx(kP).margin(0.02));
    CHECK(r.initial_mode_rss[std::size_t(q0)] < r.initial_mode_rss[std::size_t(1 - q0)]);
  }
}

// At σ = 1 % of the level range the 16-sample windows see a switch at about 3 standard deviations:
// the window is widened with the noise, and every switch is found, on its map, near its instant.
TEST_CASE("pump tank at 1 % noise: the kink window widens and every switch is found") {
  const double dt = 0.01, sigma = 1e-2;
  const Model model{PumpTank{}};
  for (unsigned seed : {21u, 22u, 23u}) {
    std::vector<int> true_modes;
    const Truth truth = TankData(1, dt, 20.0, sigma, seed, &true_modes);
    IdentifierSettings settings;
    settings.sets = false;
    const IdentifyResult r = Identify(model, truth.y, dt, settings);
    INFO("seed " << seed);
    CHECK(r.initial_mode == 1);
    REQUIRE(r.events.size() == truth.samples.size());
    for (std::size_t i = 0; i < r.events.size(); ++i) {
      INFO("switch " << i << " at t = " << truth.times[i] << ", found at t = " << r.events[i].time);
      CHECK(std::abs(r.events[i].time - truth.times[i]) <= 4 * dt);
      CHECK(r.events[i].map == truth.maps[i]);
    }
  }
}

TEST_CASE("a given initial mode is used as given") {
  std::vector<int> true_modes;
  const Truth truth = TankData(1, 0.01, 6.0, 1e-3, 5u, &true_modes);
  IdentifyOptions options;
  options.initial_mode = 0;  // wrong on purpose: the walk follows it
  IdentifierSettings settings;
  settings.sets = false;
  const IdentifyResult r = Identify(Model{PumpTank{}}, truth.y, 0.01, settings, options);
  CHECK_FALSE(r.initial_mode_inferred);
  CHECK(r.initial_mode == 0);
  CHECK(r.mode[0] == 0);
  options.initial_mode = 2;
  CHECK_THROWS_AS(Identify(Model{PumpTank{}}, truth.y, 0.01, settings, options), std::invalid_argument);
}

TEST_CASE("both modes and a jump in mode 1: the jumps are found against each sample's own mode's flow") {
  const Model model{testing::RefillTank{}};
  const double dt = 0.01, sigma = 1e-3;
  const Trajectory run = Simulate(model, testing::Of({2.0}), SampleGrid{.t_end = 15.0, .dt = dt});
  REQUIRE(run.status.completed());
  REQUIRE(run.jumps.size() == 8);  // 4 switches to drain, 4 refills
  const long refills = std::count_if(run.jumps.begin(), run.jumps.end(), [](const JumpRecord& j) { return j.map == 0; });
  IdentifierSettings settings;
  settings.sets = false;
  settings.detector.kind = DetectorKind::kResidual;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    INFO("seed " << seed);
    const Mat y = AddMeasurementNoise(run.x, Vec::Constant(1, sigma), NoiseKey{.seed = seed});
    // Mode fill's flow alone misses P·δt = 20 σ per step while the tank drains: that pass flags runs
    // of pairs after the switches, many more than there are jumps.
    IdentifyOptions one_mode;
    one_mode.assign_events = false;
    CHECK(Identify(model, y, dt, settings, one_mode).jumps_detected > 5 * refills);
    const IdentifyResult r = Identify(model, y, dt, settings);
    REQUIRE(r.events.size() == run.jumps.size());
    CHECK(r.events_reason.empty());
    CHECK(r.initial_mode == 0);
    for (std::size_t i = 0; i < run.jumps.size(); ++i) {
      const JumpRecord& truth = run.jumps[i];
      const long sample = static_cast<long>(std::ceil(truth.t / dt));
      INFO("event " << i << " at t = " << truth.t << " (map " << truth.map << ")");
      CHECK(r.events[i].map == truth.map);
      CHECK(r.events[i].jump == (truth.map == 0));
      CHECK(std::abs(r.events[i].sample - sample) <= 1);
    }
    // c from the refills' pairs (x⁺ = c·x⁻, both at σ = 1e-3 around x⁻ = 1): within 0.05 of 2.
    CHECK(r.beta_hat[0] == Approx(2.0).margin(0.05));
    long same = 0;
    for (std::size_t k = 0; k < run.q.size(); ++k) same += run.q[k] == r.mode[k] ? 1 : 0;
    CHECK(static_cast<double>(same) / static_cast<double>(run.q.size()) > 0.99);
  }
}

TEST_CASE("the jump localiser is refused for an automaton, by its field") {
  std::vector<int> true_modes;
  const Truth truth = TankData(1, 0.01, 2.0, 1e-3, 5u, &true_modes);
  IdentifierSettings settings;
  settings.localize = true;
  CHECK_THROWS_WITH(Identify(Model{PumpTank{}}, truth.y, 0.01, settings, IdentifyOptions{}),
                    Catch::Matchers::StartsWith("IdentifierSettings::localize: not available for hybrid automaton "
                                                "'pump-tank'"));
}

// The pump tank with its levels as guard parameters γ = (h_lo, h_hi), both unknown.
struct PumpTankLevels : PumpTank {
  ModelSpec Spec() const {
    ModelSpec s = PumpTank::Spec();
    s.guard_params = {Param("h_lo", kLow), Param("h_hi", kHigh)};
    return s;
  }
  void Guards(ConstVecRef x, const Context& ctx, VecRef h) const {
    h(0) = x(0) - ctx.gamma[0];
    h(1) = x(0) - ctx.gamma[1];
  }
};

TEST_CASE("pump tank: the levels' start from each switch's own guard") {
  const double dt = 0.01;
  std::vector<int> true_modes;
  const Truth truth = TankData(1, dt, 20.0, 1e-3, 3u, &true_modes);
  Model model{PumpTankLevels{}};
  IdentifierSettings settings;
  settings.sets = false;
  const IdentifyResult r = Identify(model, truth.y, dt, settings);
  REQUIRE(r.events.size() == truth.samples.size());
  Vec gamma0(2);
  gamma0 << 1.3, 1.7;  // a poor start: both levels nearer the middle
  model.SetParameter("h_lo", gamma0[0]);
  model.SetParameter("h_hi", gamma0[1]);
  std::vector<int> maps;
  for (const AutomatonEvent& e : r.events) maps.push_back(e.map);
  std::vector<double> t;
  for (Eigen::Index k = 0; k < truth.y.cols(); ++k) t.push_back(static_cast<double>(k) * dt);
  const Unknowns unknowns = Unknowns::Of(model);
  REQUIRE(unknowns.gamma.size() == 2);
  Mat rows(0, 2);
  Vec rhs(0);
  AppendGuardRows(model, t, truth.y, r.gamma, r.alpha_hat, gamma0, unknowns, &rows, &rhs, maps, r.initial_mode);
  REQUIRE(rows.rows() == static_cast<Eigen::Index>(r.events.size()));
  const Vec start = SolveGuardRows(unknowns, rows, rhs, gamma0);
  // The pre-switch sample moved half a step lies within half a step's rise (about 0.003) of its level.
  CHECK(start[0] == Approx(kLow).margin(5e-3));
  CHECK(start[1] == Approx(kHigh).margin(5e-3));
}

// The run loop's own data (sim/: exact event location) with noise σ on every state: each detected
// event is one of the trajectory's jump records, at its sample (within one) and with its map.
void CheckAgainstRun(const Model& model, const Trajectory& run, double sigma, unsigned seed) {
  Mat y = run.x;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  for (Eigen::Index k = 0; k < y.cols(); ++k) {
    for (Eigen::Index i = 0; i < y.rows(); ++i) y(i, k) += noise(rng);
  }
  IdentifierSettings settings;
  settings.sets = false;
  // The residual detector: the paper's misses the impacts of its warm-up (the first within 0.1 s).
  settings.detector.kind = DetectorKind::kResidual;
  const IdentifyResult r = Identify(model, y, run.dt, settings);
  REQUIRE(r.events.size() == run.jumps.size());
  CHECK(r.events_reason.empty());
  for (std::size_t i = 0; i < r.events.size(); ++i) {
    const long truth = static_cast<long>(std::ceil(run.jumps[i].t / run.dt - 1e-9));
    INFO("record " << i << " at t = " << run.jumps[i].t);
    CHECK(std::abs(r.events[i].sample - truth) <= 1);
    CHECK(r.events[i].map == run.jumps[i].map);
    CHECK(r.events[i].mode_after == run.jumps[i].mode);
  }
  if (!run.q.empty()) CHECK(r.initial_mode == run.q.front());
}

TEST_CASE("the run loop's floor-ceiling ball and pump tank: every event found and assigned to its map") {
  const Model ball{testing::FloorCeiling{}};
  Vec x0(2);
  x0 << 0.5, 8.0;  // two ceiling impacts, then the floor's
  const Trajectory bounces = Simulate(ball, x0, SampleGrid{.t_end = 2.5, .dt = 1e-3});
  REQUIRE(bounces.status.stop == SimStop::kCompleted);
  REQUIRE(std::count_if(bounces.jumps.begin(), bounces.jumps.end(), [](const JumpRecord& j) { return j.map == 1; }) >= 2);
  CheckAgainstRun(ball, bounces, 1e-3, 21u);
  const Model tank{testing::PumpTank{}};
  for (int q0 : {0, 1}) {
    Exogenous exo;
    exo.initial_mode = q0;
    const Trajectory run = Simulate(tank, Vec::Constant(1, 1.5), SampleGrid{.t_end = 20.0, .dt = 1e-2}, {}, exo);
    REQUIRE(run.status.stop == SimStop::kCompleted);
    CheckAgainstRun(tank, run, 1e-3, 31u + unsigned(q0));
  }
}

}  // namespace
}  // namespace hysid
