// Multiple shooting by time on systems whose detector labels cannot start a fit: a thermostat whose
// narrow band the start's thresholds miss (the data's switches located, γ moved onto them), one whose
// start heater cools (α from the modes the data show, nodes set against the data), cascaded
// tanks with the upper level hidden and an overflow guard in α, γ and the input (a start past the
// rim put on it), and the past-zero projection's sensitivities against finite differences.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <utility>

#include <Eigen/Dense>
#include <tbb/global_control.h>

#include "core/model_file/model_file.hpp"
#include "sim/measurement.hpp"
#include "tests/sim/refine/at_the_bound.hpp"
#include "sim/refine/mode_start.hpp"
#include "sim/refine/start.hpp"
#include "sim/refine/time_shooting.hpp"
#include "sim/sensitivity/crlb.hpp"

namespace hysid {
namespace {

// T' = −k (T − 10) + P q: the heater on (q = 1) below T_lo, off above T_hi, a band of 1 K; the mode
// is not measured.
constexpr const char* kThermostat = R"toml(
name = "thermostat"
states = ["T"]
modes = ["off", "on"]
alpha = [
  { name = "k", value = 0.001, bounds = [0.0, 1.0] },
  { name = "P", value = 0.022, bounds = [0.0, 10.0] },
]
guard_params = [
  { name = "T_lo", value = 20.5, bounds = [10.0, 40.0] },
  { name = "T_hi", value = 21.5, bounds = [10.0, 40.0] },
]
[[flow]]
mode = "off"
phi = [["-(T - 10)", 0]]
[[flow]]
mode = "on"
phi = [["-(T - 10)", 1]]
[[jump]]
name = "heat-on"
from = "off"
to = "on"
guard = "cold"
[[jump]]
name = "heat-off"
from = "on"
to = "off"
guard = "hot"
[[guard]]
name = "cold"
h = "T - T_lo"
direction = "falling"
[[guard]]
name = "hot"
h = "T - T_hi"
direction = "rising"
[defaults]
x0 = [21.0]
mode = "on"
t_end = 1800.0
dt = 1.0
)toml";

// Two tanks, the lower level measured; the upper overflows at its rim H (held there) until the pump's
// inflow k1 u falls below the outflow a1 √H.
constexpr const char* kTanks = R"toml(
name = "tanks"
states = ["h1", "h2"]
measured = ["h2"]
inputs = ["u"]
input_defaults = { u = "4.3 + 1.2*sin(0.0209*t) + 0.6*sin(0.0571*t + 1)" }
modes = ["normal", "overflow"]
alpha = [
  { name = "k1", value = 0.1, bounds = [0.0, 10.0] },
  { name = "a1", value = 0.15, bounds = [0.0, 10.0] },
  { name = "a2", value = 0.12, bounds = [0.0, 10.0] },
]
guard_params = [ { name = "H", value = 9.0, bounds = [1.0, 20.0] } ]
[[flow]]
mode = "normal"
phi = [["u", "-sqrt(h1)", 0], [0, "sqrt(h1)", "-sqrt(h2)"]]
rows = ["h1", "h2"]
[[flow]]
mode = "overflow"
phi = [[0, 0, 0], [0, "sqrt(h1)", "-sqrt(h2)"]]
rows = ["h2"]
[[jump]]
name = "overflow-start"
from = "normal"
to = "overflow"
guard = "rim"
[[jump]]
name = "overflow-end"
from = "overflow"
to = "normal"
guard = "pump-low"
[[guard]]
name = "rim"
h = "h1 - H"
direction = "rising"
project = { h1 = "H" }
[[guard]]
name = "pump-low"
h = "k1*u - a1*sqrt(H)"
direction = "falling"
[defaults]
x0 = [6.0, 4.0]
mode = "normal"
t_end = 1200.0
dt = 2.0
)toml";

// The input of kTanks on the grid's times.
InputSignal TankInput(const SampleGrid& grid) {
  InputSignal u;
  for (long k = 0; k < grid.size(); ++k) u.times.push_back(static_cast<double>(k) * grid.dt);
  u.values.resize(1, static_cast<Eigen::Index>(u.times.size()));
  for (std::size_t k = 0; k < u.times.size(); ++k) {
    const double t = u.times[k];
    u.values(0, Eigen::Index(k)) = 4.3 + 1.2 * std::sin(0.0209 * t) + 0.6 * std::sin(0.0571 * t + 1);
  }
  return u;
}

// Measured: from this start (k, P 0.47× and 0.62×, the band 20.21–21.95) the thresholds never move
// without the located switches (the model never switches where the data do: γ has no gradient).
TEST_CASE("a narrow-band thermostat from thresholds that miss the band: at the bound", "[time_shooting]") {
  const Model model = ParseModelFile(kThermostat, "thermostat.toml").model;
  const SampleGrid grid{1800.0, 1.0};
  const Vec x0 = Vec::Constant(1, 21.0);
  Exogenous exo;
  exo.initial_mode = 1;  // heating
  const Trajectory truth = Simulate(model, x0, grid, {}, exo);
  REQUIRE(truth.status.completed());
  REQUIRE(truth.jumps.size() >= 15);
  const Mat y = AddMeasurementNoise(truth.x, Vec::Constant(1, 0.05), NoiseKey{.seed = 7, .stream = 0});
  HybridParameters start = HybridParameters::Of(model, x0);
  start.alpha << 0.00047, 0.0136;
  start.gamma = (Vec(2) << 20.21, 21.95).finished();
  RefineOptions options;
  options.sigma = Vec::Constant(1, 0.05);
  RefineChain chain = RefineChain::Uniform(y, grid.dt, std::vector<std::uint8_t>(truth.t.size(), 0));
  const RefineResult r = FitByTimeShooting(model, {chain}, start, options);
  const Unknowns u = Unknowns::Of(model);
  RequireAtTheBound(r, HybridParameters::Of(model, x0).Theta(u),
                    ComputeCrlb(model, HybridParameters::Of(model, x0), grid, Vec::Constant(1, 0.05), u, {}, {},
                                nullptr));
}

// The thermostat's data (σ = 0.05, seed `seed`), its true mode per sample in `q`.
Mat ThermostatData(const Model& model, std::uint64_t seed, std::vector<int>* q) {
  Exogenous exo;
  exo.initial_mode = 1;
  const Trajectory truth = Simulate(model, Vec::Constant(1, 21.0), SampleGrid{1800.0, 1.0}, {}, exo);
  REQUIRE(truth.status.completed());
  REQUIRE(truth.jumps.size() >= 15);
  if (q != nullptr) q->assign(truth.q.begin(), truth.q.end());
  return AddMeasurementNoise(truth.x, Vec::Constant(1, 0.05), NoiseKey{.seed = seed, .stream = 0});
}

// The start's heater cools at the band (P − k·11 < 0): every window's best mode at the start is "on",
// and a fit on those modes collapses. The windows' modes found by expectation–maximisation give α
// within 3 % of the least squares on the windows that the true modes leave whole (computed here from
// the thermostat's φ written out: ΔT = −k Σ ½(T_{k−1} + T_k − 20) + P q W).
TEST_CASE("a thermostat whose start heater cools: α from the modes the data show", "[time_shooting]") {
  const Model model = ParseModelFile(kThermostat, "thermostat.toml").model;
  std::vector<int> q;
  const Mat y = ThermostatData(model, 11, &q);
  HybridParameters start = HybridParameters::Of(model, Vec::Constant(1, 21.0));
  start.alpha << 0.0021, 0.0203;
  start.gamma = (Vec(2) << 20.36, 20.85).finished();
  REQUIRE(start.alpha[1] - 11.0 * start.alpha[0] < 0.0);
  const long window = 9;
  const RefineChain chain = RefineChain::Uniform(y, 1.0, std::vector<std::uint8_t>(std::size_t(y.cols()), 0));
  const std::optional<Vec> alpha = ModeClusteredAlpha(model, {chain}, {0}, start, Unknowns::Of(model), window);
  REQUIRE(alpha.has_value());
  Eigen::Matrix2d ata = Eigen::Matrix2d::Zero();
  Eigen::Vector2d atb = Eigen::Vector2d::Zero();
  for (long a = 0; a + window < y.cols(); a += window) {
    bool whole = true;
    for (long k = a; k <= a + window; ++k) whole = whole && q[std::size_t(k)] == q[std::size_t(a)];
    if (!whole) continue;
    double integral = 0.0;
    for (long k = a + 1; k <= a + window; ++k) integral += 0.5 * (y(0, k - 1) + y(0, k) - 20.0);
    const Eigen::RowVector2d row(-integral, q[std::size_t(a)] * double(window));
    ata += row.transpose() * row;
    atb += row.transpose() * (y(0, a + window) - y(0, a));
  }
  const Eigen::Vector2d whole_windows = ata.ldlt().solve(atb);
  CHECK((*alpha)[0] == Approx(whole_windows[0]).epsilon(0.03));
  CHECK((*alpha)[1] == Approx(whole_windows[1]).epsilon(0.03));
  // Not for a model whose every state is not measured, nor for one mode.
  CHECK_FALSE(ModeClusteredAlpha(model, {chain}, {}, start, Unknowns::Of(model), 0).has_value());
}

// The whole refinement (Refine: the labelled routes, then multiple shooting by time from each start)
// from the model's own start values, with no detected label: at the bound. Measured: without α from
// the modes (ModeClusteredAlpha returning nothing) the residual tests refuse this fit (residual-rms).
// With every segment's run made on its own thread, it gives the same estimate, standard errors,
// cost and iterations, bit for bit, on one thread.
TEST_CASE("a thermostat from a start whose heater cools: at the bound, bit for bit the same on one thread",
          "[time_shooting]") {
  Model model = ParseModelFile(kThermostat, "thermostat.toml").model;
  const Vec x0 = Vec::Constant(1, 21.0);
  const HybridParameters truth = HybridParameters::Of(model, x0);
  const Mat y = ThermostatData(model, 5, nullptr);
  for (const auto& [name, value] : {std::pair{"k", 0.0020752}, {"P", 0.0202873}, {"T_lo", 20.355}, {"T_hi", 20.851}}) {
    model.SetParameter(name, value);
  }
  RefineOptions options;
  options.sigma = Vec::Constant(1, 0.05);
  const RefineChain chain = RefineChain::Uniform(y, 1.0, std::vector<std::uint8_t>(std::size_t(y.cols()), 0));
  const RefineResult r = Refine(model, {chain}, model.alpha(), model.beta(), options);
  const Unknowns u = Unknowns::Of(model);
  RequireAtTheBound(r, truth.Theta(u),
                    ComputeCrlb(ParseModelFile(kThermostat, "thermostat.toml").model, truth, SampleGrid{1800.0, 1.0},
                                Vec::Constant(1, 0.05), u, {}, {}, nullptr));
  const RefineResult one = [&] {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    return Refine(model, {chain}, model.alpha(), model.beta(), options);
  }();
  REQUIRE(one.route == r.route);
  CHECK(one.mended == r.mended);
  CHECK(one.iterations == r.iterations);
  CHECK(one.final_cost == r.final_cost);
  CHECK(one.refined.Theta(u) == r.refined.Theta(u));
  CHECK(one.standard_errors == r.standard_errors);
}

// A 60 s dropout in a run (two chains, the second after the gap): the model runs through it, one
// trajectory with one initial state, and the fit is at the bound of the samples the data hold (the
// Fisher information summed here over those samples from the sensitivities of one run).
TEST_CASE("a thermostat with a dropout: the run fitted through the gap at the bound of its samples", "[time_shooting]") {
  const Model model = ParseModelFile(kThermostat, "thermostat.toml").model;
  std::vector<int> q;
  const Mat y = ThermostatData(model, 3, &q);
  const long gap_first = 600, gap_end = 660;
  std::vector<double> t(std::size_t(y.cols()));
  for (std::size_t k = 0; k < t.size(); ++k) t[k] = double(k);
  auto chain = [&](long a, long b) {
    return RefineChain::Of(std::vector<double>(t.begin() + a, t.begin() + b), y.middleCols(a, b - a),
                           std::vector<std::uint8_t>(std::size_t(b - a), 0));
  };
  std::vector<RefineChain> chains = {chain(0, gap_first), chain(gap_end, y.cols())};
  chains[1].after_gap = true;
  HybridParameters truth = HybridParameters::Of(model, Vec::Constant(1, 21.0));
  truth.initial_mode = 1;
  RefineOptions options;
  options.sigma = Vec::Constant(1, 0.05);
  const RefineResult r = FitByTimeShooting(model, chains, truth, options);
  CHECK(r.gaps_joined == 1);
  CHECK(r.chains_used == 2);
  const Unknowns u = Unknowns::Of(model);
  const SensitivityTrajectory run = SimulateSensitivities(model, truth, u, SampleGrid{1800.0, 1.0});
  REQUIRE(run.ok());
  Mat fisher = Mat::Zero(u.size(1), u.size(1));
  for (long k = 0; k < y.cols(); ++k) {
    if (k >= gap_first && k < gap_end) continue;
    const Eigen::RowVectorXd row = run.S(k).row(0);
    fisher += row.transpose() * row / (0.05 * 0.05);
  }
  RequireAtTheBound(r, truth.Theta(u), CrlbFromFisher(fisher, u, r.names));
  // The second chain's state is the fitted run's at its first sample: near the truth there.
  REQUIRE(r.chain_x0.size() == 2);
  REQUIRE(r.chain_x0[1].size() == 1);
  CHECK(std::abs(r.chain_x0[1][0] - run.trajectory.x(0, gap_end)) < 0.02);
  CHECK(r.chain_mode[1] == q[std::size_t(gap_end)]);
  // Its covariance with θ: the bound's carried to the state at the gap's end, J F⁻¹ Jᵀ with
  // J = [I 0; ∂x(t)/∂θ ∂x(t)/∂x0] from the one run.
  REQUIRE(r.chain_covariance.size() == 2);
  const Mat* second = r.covariance_of_chain(1, 1);
  REQUIRE(second != nullptr);
  CHECK(r.covariance_of_chain(0, 1)->isApprox(r.covariance));
  const Eigen::Index p = u.size(1);
  Mat J = Mat::Identity(p, p);
  J.row(p - 1) = run.S(gap_end).row(0);
  const Mat carried = J * fisher.inverse() * J.transpose();
  for (Eigen::Index i = 0; i < p; ++i) {
    CAPTURE(i);
    CHECK(std::sqrt((*second)(i, i)) == Approx(std::sqrt(carried(i, i))).epsilon(0.1));
  }
  CHECK((*second)(p - 1, 0) / std::sqrt((*second)(p - 1, p - 1) * (*second)(0, 0)) ==
        Approx(carried(p - 1, 0) / std::sqrt(carried(p - 1, p - 1) * carried(0, 0))).margin(0.1));
}

TEST_CASE("cascaded tanks, the upper level hidden, the overflow ending in α, γ and u: at the bound from far off",
          "[time_shooting]") {
  const Model model = ParseModelFile(kTanks, "tanks.toml").model;
  const SampleGrid grid{1200.0, 2.0};
  const InputSignal u = TankInput(grid);
  const Vec x0 = (Vec(2) << 6.0, 4.0).finished();
  Exogenous exo;
  exo.inputs = &u;
  const Trajectory truth = Simulate(model, x0, grid, {}, exo);
  REQUIRE(truth.status.completed());
  REQUIRE(truth.jumps.size() >= 6);
  const double sigma = 0.02;
  const Mat y = AddMeasurementNoise(truth.x, Vec::Constant(2, sigma), NoiseKey{.seed = 5, .stream = 0});
  Mat data = Mat::Constant(2, y.cols(), std::nan(""));
  data.row(1) = y.row(1);
  HybridParameters start = HybridParameters::Of(model, x0);
  // k1, a1, a2 1.3×, 0.8×, 1.25×, the rim at 0.83× its height and the hidden level 1.25× (past that
  // rim: put on it). Measured: from k1, a1, a2 1.5×, 0.67×, 1.5×, a rim at 6 and h1(0) = 9 the fit
  // ends singular (the model's upper tank never reaches its rim where the data's overflows: H has no
  // gradient, and the nodes' best modes do not tell the hidden switch).
  start.alpha << 0.13, 0.12, 0.15;
  start.gamma = Vec::Constant(1, 7.5);
  start.x0[0] = 7.5;
  RefineOptions options;
  options.sigma = Vec::Constant(2, sigma);
  options.measured = {1};
  const RefineChain chain = RefineChain::Of(truth.t, data, std::vector<std::uint8_t>(truth.t.size(), 0), u.values);
  const RefineResult r = FitByTimeShooting(model, {chain}, start, options);
  const Unknowns unknowns = Unknowns::Of(model);
  RequireAtTheBound(r, HybridParameters::Of(model, x0).Theta(unknowns),
                    ComputeCrlb(model, HybridParameters::Of(model, x0), grid, Vec::Constant(1, sigma), unknowns, {},
                                {1}, &u));
}

// The whole refinement from a model file's values far off: k1/a1 3.6 × too low (the upper level's
// steady state 13 × too low), a2 1.45 ×, the rim H at 19.7, which that model never reaches, the
// hidden level 2 ×. Measured: no start before the design's points gives an ok fit; one of them
// reaches the bound (44 s of CPU).
TEST_CASE("cascaded tanks from a far model file: a point of the start's box reaches the bound", "[time_shooting]") {
  Model model = ParseModelFile(kTanks, "tanks.toml").model;
  const SampleGrid grid{1200.0, 2.0};
  const InputSignal u = TankInput(grid);
  const Vec x0 = (Vec(2) << 6.0, 4.0).finished();
  const HybridParameters truth = HybridParameters::Of(model, x0);
  Exogenous exo;
  exo.inputs = &u;
  const Trajectory run = Simulate(model, x0, grid, {}, exo);
  REQUIRE(run.status.completed());
  const double sigma = 0.02;
  const Mat y = AddMeasurementNoise(run.x, Vec::Constant(2, sigma), NoiseKey{.seed = 11, .stream = 0});
  Mat data = Mat::Constant(2, y.cols(), std::nan(""));
  data.row(1) = y.row(1);
  for (const auto& [name, value] : {std::pair{"k1", 0.04038}, {"a1", 0.21978}, {"a2", 0.17368}, {"H", 19.738}}) {
    model.SetParameter(name, value);
  }
  // The hidden level's start as `identify` makes it: the file's model simulated from its x0 (h1 = 3.9).
  const Trajectory reconstruction = Simulate(model, (Vec(2) << 11.905, y(1, 0)).finished(), grid, {}, exo);
  REQUIRE(reconstruction.status.completed());
  data.row(0) = reconstruction.x.row(0);
  RefineOptions options;
  options.sigma = Vec::Constant(1, sigma);
  options.measured = {1};
  RefineChain chain = RefineChain::Of(run.t, data, std::vector<std::uint8_t>(run.t.size(), 0), u.values);
  chain.initial_mode = 0;
  const RefineResult r = Refine(model, {chain}, model.alpha(), model.beta(), options);
  INFO(r.mended);
  CHECK(r.mended.find("design point") != std::string::npos);
  const Unknowns unknowns = Unknowns::Of(model);
  RequireAtTheBound(r, truth.Theta(unknowns),
                    ComputeCrlb(ParseModelFile(kTanks, "tanks.toml").model, truth, grid, Vec::Constant(1, sigma),
                                unknowns, {}, {1}, &u));
}

// A run from a state past a projecting guard: the state is put on the guard (no chatter between the
// overflow's start and end), and the sensitivities after it agree with central differences of runs.
TEST_CASE("a start past the rim is put on it, with sensitivities that match finite differences", "[time_shooting]") {
  const Model model = ParseModelFile(kTanks, "tanks.toml").model;
  const SampleGrid grid{10.0, 2.0};  // overflowing throughout (u > a1 √H / k1 = 4.5)
  const InputSignal u = TankInput(grid);
  HybridParameters at = HybridParameters::Of(model, (Vec(2) << 10.5, 4.0).finished());  // H = 9
  const Unknowns unknowns = Unknowns::Of(model);
  SensitivityOptions options;
  options.sim.rtol = options.sim.atol = 1e-12;
  options.sim.input_kink = 0.0;  // a stop at every input sample: runs whose steps differ agree to rtol
  const SensitivityTrajectory s = SimulateSensitivities(model, at, unknowns, grid, options, &u);
  REQUIRE(s.ok());
  REQUIRE_FALSE(s.trajectory.jumps.empty());
  CHECK(s.trajectory.jumps.front().post[0] == Approx(9.0));
  REQUIRE(s.trajectory.q.back() == 1);  // overflowing
  CHECK(s.trajectory.x(0, s.trajectory.size() - 1) == Approx(9.0));
  const Vec theta = at.Theta(unknowns);
  const long k = s.trajectory.size() - 1;
  for (Eigen::Index c = 0; c < theta.size(); ++c) {
    const double h = 1e-6 * std::max(1.0, std::abs(theta[c]));
    Vec plus = theta, minus = theta;
    plus[c] += h;
    minus[c] -= h;
    const Trajectory a = SimulateSensitivities(model, at.WithTheta(unknowns, plus), unknowns, grid, options, &u).trajectory;
    const Trajectory b = SimulateSensitivities(model, at.WithTheta(unknowns, minus), unknowns, grid, options, &u).trajectory;
    REQUIRE(a.size() == s.trajectory.size());
    REQUIRE(b.size() == s.trajectory.size());
    for (int j = 0; j < 2; ++j) {
      const double fd = (a.x(j, k) - b.x(j, k)) / (2 * h);
      INFO("state " << j << ", column " << c);
      CHECK(s.S(k)(j, c) == Approx(fd).margin(1e-5).epsilon(1e-3));
    }
  }
}


// A heater on from 21 °C for 300 s whose thresholds are set far beyond the band (T_hi = 40): the model
// never switches, and the guard "hot" moves to where the run reaches it on kGuardReach of its samples.
// Noise-free data of the same α: each segment's run from its node is the trajectory itself, so the
// value is its quantile, computed here from one simulation.
TEST_CASE("a guard the runs never reach moves to where they reach it", "[time_shooting]") {
  Model model = ParseModelFile(kThermostat, "thermostat.toml").model;
  model.SetParameter("T_lo", 12.0);
  model.SetParameter("T_hi", 40.0);
  Exogenous exo;
  exo.initial_mode = 1;
  const Trajectory run = Simulate(model, Vec::Constant(1, 21.0), SampleGrid{300.0, 1.0}, {}, exo);
  REQUIRE(run.jumps.empty());
  RefineChain chain = RefineChain::Uniform(run.x, 1.0, std::vector<std::uint8_t>(run.t.size(), 0));
  chain.initial_mode = 1;
  HybridParameters start = HybridParameters::Of(model, Vec::Constant(1, 21.0));
  start.initial_mode = 1;
  RefineOptions options;
  options.sigma = Vec::Constant(1, 0.05);
  const std::optional<Vec> gamma = GammaReachingGuards(model, {chain}, start, options);
  REQUIRE(gamma.has_value());
  std::vector<double> t_values(run.x.data(), run.x.data() + run.x.cols());
  std::sort(t_values.begin(), t_values.end());
  const double expected = t_values[std::size_t((1.0 - kGuardReach) * double(t_values.size() - 1))];
  CHECK((*gamma)[1] == Approx(expected).margin(1e-5));
  CHECK((*gamma)[0] == 12.0);  // "cold" leaves the mode "off", which no run is in
  // Thresholds the data cross: the runs switch, nothing moves.
  const Model crossing = ParseModelFile(kThermostat, "thermostat.toml").model;
  const Mat y = ThermostatData(crossing, 2, nullptr);
  RefineChain switching = RefineChain::Uniform(y, 1.0, std::vector<std::uint8_t>(std::size_t(y.cols()), 0));
  switching.initial_mode = 1;
  CHECK_FALSE(GammaReachingGuards(crossing, {switching}, HybridParameters::Of(crossing, Vec::Constant(1, 21.0)),
                                  options).has_value());
}

// The design's point k: each unknown entry times factor^(2 h − 1), h the radical inverse of k in the
// entry's prime base (k = 1: 1/2, 1/3; k = 5: 0.101₂ = 5/8, 12₃ = 7/9); known entries and γ kept;
// bounds hold.
TEST_CASE("design starts: a Halton sequence over the box within the factor", "[time_shooting]") {
  const Model model = ParseModelFile(kThermostat, "thermostat.toml").model;
  const HybridParameters center = HybridParameters::Of(model, Vec::Constant(1, 21.0));
  const std::vector<HybridParameters> design = DesignStarts(model, center, 16, 2.5);
  REQUIRE(design.size() == 16);
  CHECK(design[0].alpha[0] == Approx(0.001 * std::pow(2.5, 0.0)));
  CHECK(design[0].alpha[1] == Approx(0.022 * std::pow(2.5, 2.0 / 3.0 - 1.0)));
  CHECK(design[4].alpha[0] == Approx(0.001 * std::pow(2.5, 2.0 * 5.0 / 8.0 - 1.0)));
  CHECK(design[4].alpha[1] == Approx(0.022 * std::pow(2.5, 2.0 * 7.0 / 9.0 - 1.0)));
  for (const HybridParameters& p : design) {
    CHECK(p.gamma == center.gamma);
    for (int i = 0; i < 2; ++i) {
      CHECK(p.alpha[i] >= center.alpha[i] / 2.5);
      CHECK(p.alpha[i] <= center.alpha[i] * 2.5);
    }
  }
  // An upper bound within the box clamps its entry.
  std::string text = kThermostat;
  const std::string p_entry = "value = 0.022, bounds = [0.0, 10.0]";
  text.replace(text.find(p_entry), p_entry.size(), "value = 0.022, bounds = [0.0, 0.023]");
  const Model bounded = ParseModelFile(text, "thermostat.toml").model;
  for (const HybridParameters& p : DesignStarts(bounded, center, 16, 2.5)) CHECK(p.alpha[1] <= 0.023);
}

}  // namespace
}  // namespace hysid
