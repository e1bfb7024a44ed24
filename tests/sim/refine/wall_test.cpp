// An unknown guard parameter estimated: the wall example (examples/wall/wall.toml, a spring–mass
// hitting a wall at x = w). Data simulated with w = 1 and noise σ = 1 mm on both states are
// identified as `hysid identify` does with its defaults, from the file's w = 0.9: ŵ within 3
// standard errors of the truth in every seed, each standard error within 20 % of the CRLB's sd at
// the truth. Also: the start of w from the detected jumps, and parameter bounds.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>

#include "core/identify/identifier.hpp"
#include "core/model_file/model_file.hpp"
#include "sim/measurement.hpp"
#include "sim/refine/refine.hpp"
#include "sim/refine/start.hpp"
#include "sim/refine/time_shooting.hpp"
#include "sim/sensitivity/crlb.hpp"

namespace hysid {
namespace {

constexpr double kSigma = 1e-3;

Model FileModel() { return ReadModelFile("examples/wall/wall.toml").model; }  // w = 0.9

struct Truth {
  Model model = [] {
    Model m = FileModel();
    m.SetParameter("w", 1.0);
    return m;
  }();
  SampleGrid grid{model.spec().default_t_end, model.spec().default_dt};
  Vec x0 = Eigen::Map<const Vec>(model.spec().default_x0.data(), 2);
  Trajectory run = Simulate(model, x0, grid);
  std::vector<std::uint8_t> labels;  // the true jump samples
  Truth() {
    labels.assign(run.j.size(), 0);
    for (std::size_t k = 1; k < run.j.size(); ++k) labels[k] = run.j[k] != run.j[k - 1];
  }
  Mat Noisy(std::uint64_t seed) const {
    return AddMeasurementNoise(run.x, Vec::Constant(2, kSigma), NoiseKey{.seed = seed, .stream = 0});
  }
};

std::size_t IndexOf(const std::vector<std::string>& names, const std::string& name) {
  const auto it = std::find(names.begin(), names.end(), name);
  REQUIRE(it != names.end());
  return static_cast<std::size_t>(it - names.begin());
}

TEST_CASE("wall: w estimated from the file's 0.9 with the defaults, within 3 SE, SE at the CRLB",
          "[refine]") {
  const Truth truth;
  REQUIRE(truth.run.status.completed());
  REQUIRE(truth.run.jumps.size() == 18);
  const Model model = FileModel();
  const Unknowns unknowns = Unknowns::Of(model);
  const Crlb bound = ComputeCrlb(truth.model, truth.x0, truth.grid, Vec::Constant(2, kSigma), unknowns);
  REQUIRE(bound.ok());
  const std::size_t w = IndexOf(bound.names, "w");
  IdentifierSettings settings;
  settings.detector.kind = DetectorKind::kResidual;
  settings.data_rtol = settings.data_atol = 1e-12;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const Mat y = truth.Noisy(seed);
    const IdentifyResult recursive = Identify(model, y, truth.grid.dt, settings);
    const RefineResult r = RefineIdentification(model, truth.run.t, y, {}, RefinementStart(recursive));
    INFO("seed " << seed << ": " << ToString(r.status) << " " << r.reason);
    REQUIRE(r.ok());
    REQUIRE(r.names == bound.names);
    const double w_hat = r.estimate.gamma[0], se = r.standard_errors[static_cast<Eigen::Index>(w)];
    const double sd = bound.sd[static_cast<Eigen::Index>(w)];
    INFO("w = " << w_hat << " ± " << se << ", CRLB sd " << sd << ", start " << r.start.gamma[0]);
    CHECK(std::abs(w_hat - 1.0) < 3.0 * se);
    CHECK(se == Approx(sd).epsilon(0.2));
    CHECK(std::abs(r.start.gamma[0] - 1.0) < 0.01);  // the start from the detected jumps
    const Vec theta = r.estimate.Theta(r.unknowns),
              true_theta = HybridParameters::Of(truth.model, truth.x0).Theta(r.unknowns);
    for (Eigen::Index i = 0; i < theta.size(); ++i) {
      INFO(r.names[static_cast<std::size_t>(i)] << " = " << theta[i] << " ± " << r.standard_errors[i]);
      CHECK(std::abs(theta[i] - true_theta[i]) < 4.0 * r.standard_errors[i]);
      CHECK(r.standard_errors[i] == Approx(bound.sd[i]).epsilon(0.2));
    }
  }
}

TEST_CASE("wall: the start of w from the detected jumps is one Newton step over them", "[refine]") {
  const Truth truth;
  const Model model = FileModel();
  const Unknowns unknowns = Unknowns::Of(model);
  // Noise-free samples: x̃ = y_{k−1} + ½ δt f lies within O(δt² |f'|) of the wall.
  Mat rows(0, 1);
  Vec rhs(0);
  AppendGuardRows(model, truth.run.t, truth.run.x, truth.labels, truth.model.alpha(), model.gamma(), unknowns,
                  &rows, &rhs);
  REQUIRE(rows.rows() == 18);
  CHECK((rows.array() + 1.0).abs().maxCoeff() < 1e-8);  // ∂(x − w)/∂w
  const Vec start = SolveGuardRows(unknowns, rows, rhs, model.gamma());
  CHECK(start[0] == Approx(1.0).margin(2e-4));
  // No row: the model's own value.
  CHECK(SolveGuardRows(unknowns, Mat(0, 1), Vec(0), model.gamma())[0] == 0.9);
}

TEST_CASE("wall: bounds hold the fit, a start outside them is moved inside", "[refine]") {
  const Truth truth;
  Model model = FileModel();
  // w bounded below the truth: the fit ends on the bound (then the jump times disagree with the data,
  // and the status says so), never beyond it.
  model.SetBounds("w", 0.5, 0.95);
  const Mat y = truth.Noisy(1);
  RefineOptions options;
  options.routes = RefineRoutesWithout({RefineRoute::kRepairedStart, RefineRoute::kGrownSpan});
  const RefineResult r = Refine(model, {RefineChain::Uniform(y, truth.grid.dt, truth.labels)},
                                truth.model.alpha(), truth.model.beta(), options);
  CHECK(r.start.gamma[0] <= 0.95);
  CHECK(r.refined.gamma[0] <= 0.95);
  CHECK_FALSE(r.ok());
  // λ's recursive start above its upper bound 1 starts at the bound.
  Vec beta0 = truth.model.beta();
  beta0[1] = 1.2;
  const RefineResult clamped = Refine(FileModel(), {RefineChain::Uniform(y, truth.grid.dt, truth.labels)},
                                      truth.model.alpha(), beta0, options);
  CHECK(clamped.start.beta[1] <= 1.0);
  CHECK(clamped.refined.beta[1] <= 1.0);
}

// `run` measured with noise σ (noise key (seed, 0)) and refined from the residual detector's
// recursive estimate by the model `start`, as `identify` does.
struct NoisyFit {
  Mat y;
  IdentifyResult recursive;
  RefineResult r;
};
NoisyFit FitNoisy(const Model& start, const Trajectory& run, double sigma, std::uint64_t seed) {
  NoisyFit f;
  f.y = AddMeasurementNoise(run.x, Vec::Constant(run.x.rows(), sigma), NoiseKey{.seed = seed, .stream = 0});
  IdentifierSettings settings;
  settings.detector.kind = DetectorKind::kResidual;
  f.recursive = Identify(start, f.y, run.dt, settings);
  f.r = RefineIdentification(start, run.t, f.y, {}, RefinementStart(f.recursive));
  return f;
}

// A leaky integrate-and-fire neuron, v' = a − b v, firing at v = θ and reset to c. Its flow is
// autonomous and one-dimensional, so every post-reset value c lies on the orbit: a reset raised by
// (f⁺/f⁻) δθ (f± = a − b c, a − b θ) with the threshold raised by δθ leaves the interspike interval
// and the trajectory the same but for the instants between the two jump times. The samples do not
// tell the two apart to first order: the information is singular, and another start cannot change
// that.
constexpr const char* kNeuron = "tests/data/lif.toml";

TEST_CASE("a neuron's threshold and reset are one direction to first order: singular-fisher, no other route",
          "[refine]") {
  const Model start = ReadModelFile(kNeuron).model;  // every value 2x off
  Model truth = start;
  truth.SetParameter("a", 2.0);
  truth.SetParameter("b", 0.5);
  truth.SetParameter("c", 0.2);
  truth.SetParameter("theta", 3.0);
  const SampleGrid grid{30.0, 0.01};
  const Vec x0 = Vec::Constant(1, 0.5);
  const Trajectory run = Simulate(truth, x0, grid);
  REQUIRE(run.status.completed());
  REQUIRE(run.jumps.size() == 11);
  // The direction: (δc, δθ) = (3.8, 1) ε moves no sample but those within 2ε s after a jump.
  const double eps = 1e-5, ratio = (2.0 - 0.5 * 0.2) / (2.0 - 0.5 * 3.0);
  Model moved = truth;
  moved.SetParameter("c", 0.2 + ratio * eps);
  moved.SetParameter("theta", 3.0 + eps);
  const Trajectory other = Simulate(moved, x0, grid);
  Model across = truth;  // the threshold alone
  across.SetParameter("theta", 3.0 + eps);
  const Trajectory alone = Simulate(across, x0, grid);
  double along = 0.0, off = 0.0;
  for (Eigen::Index k = 0; k < run.x.cols(); ++k) {
    along = std::max(along, std::abs(other.x(0, k) - run.x(0, k)));
    off = std::max(off, std::abs(alone.x(0, k) - run.x(0, k)));
  }
  CHECK(along < 1e-8);  // O(ε²)
  CHECK(off > 1e-5);    // O(ε): the threshold alone moves every later sample
  const NoisyFit fit = FitNoisy(start, run, 0.02, 7);
  const Mat& y = fit.y;
  const RefineResult& r = fit.r;
  INFO(ToString(r.status) << ": " << r.reason);
  CHECK(r.status == RefineStatus::kSingularFisher);
  CHECK(r.at_the_noise);
  CHECK(r.samples_used == grid.size());
  CHECK(r.standard_errors.size() == 0);
  for (const std::string& tried : r.routes_tried) {
    INFO(tried);
    CHECK(tried.find("multiple shooting") == std::string::npos);
  }
  CHECK(std::abs(r.estimate.gamma[0] - 3.0) < 0.05);
  // The data determine a, b and v0, not c or θ: their standard errors at the refined point are the
  // bound there with θ held known (any entry of the null direction held gives the same), to 2 %: the
  // fits' information is their own (on the labels, or with the shooting nodes' states), the bound's
  // that of a plain run (1.0-1.3 % apart here).
  REQUIRE(r.names == std::vector<std::string>{"a", "b", "c", "theta", "x0[v]"});
  const Crlb at = ComputeCrlb(start, r.refined, grid, r.sigma, r.unknowns);
  REQUIRE(at.status == CrlbStatus::kSingular);
  const Crlb held = CrlbFromFisher(at.fisher, r.unknowns, r.names, {3});
  REQUIRE(held.ok());
  auto determined = [&](const RefineResult& fit, double tolerance) {
    const Vec& se = fit.determined_standard_errors;
    REQUIRE(se.size() == 5);
    CHECK(std::isnan(se[2]));
    CHECK(std::isnan(se[3]));
    const Vec theta = fit.refined.Theta(fit.unknowns),
              truth_theta = HybridParameters::Of(truth, x0).Theta(fit.unknowns);
    for (const int i : {0, 1, 4}) {
      INFO(fit.names[std::size_t(i)] << " = " << theta[i] << " ± " << se[i]);
      CHECK(se[i] == Approx(held.sd[i]).epsilon(tolerance));
      CHECK(std::abs(theta[i] - truth_theta[i]) < 4.0 * se[i]);
    }
  };
  determined(r, 0.02);
  // Multiple shooting by time from the truth ends the same way, with the same determined entries.
  const RefineResult shot =
      FitByTimeShooting(start, {RefineChain::Uniform(y, grid.dt, std::vector<std::uint8_t>(y.cols(), 0))},
                        HybridParameters::Of(truth, x0), RefineOptions{});
  INFO(ToString(shot.status) << ": " << shot.reason);
  CHECK(shot.status == RefineStatus::kSingularFisher);
  determined(shot, 0.02);
}

// A tank drained through an orifice, h' = −k√h, refilled by δ when it falls to the mark h_low. Between
// samples 0.5 s apart the data see each refill's level only through √(h_low + δ) − √h_low (the drain
// from the mark is the same curve as from any level above it): h_low and δ are one direction, k and
// h(0) are determined. The residual detector finds 1 of the 9 refills, so the labelled routes fail;
// multiple shooting by time fits the data to the noise with a singular information, and that fit is
// the result, with what the data determine.
constexpr const char* kRefill = R"toml(
name = "refill"
states = ["h"]
alpha = [{ name = "k", value = 0.3 }]
beta = [{ name = "keep", value = 1.0, known = true }, { name = "delta", value = 1.5 }]
guard_params = [{ name = "h_low", value = 0.8, bounds = [0.05, 5.0] }]
[flow]
phi = [["-sqrt(max(h, 0))"]]
rows = ["h"]
[jump]
psi = [["h", 1]]
rows = ["h"]
[[guard]]
name = "low"
h = "h - h_low"
direction = "falling"
project = { h = "h_low" }
[sets]
C = "h >= h_low"
D = "h <= h_low"
[defaults]
x0 = [2.0]
t_end = 40.0
dt = 0.5
)toml";

TEST_CASE(
    "a refill tank's mark and refill are one direction: the time-shooting fit at the noise is the result",
    "[refine]") {
  const Model model = ParseModelFile(kRefill, "refill.toml").model;
  const SampleGrid grid{40.0, 0.5};
  const Vec x0 = Vec::Constant(1, 2.0);
  const Trajectory run = Simulate(model, x0, grid);
  REQUIRE(run.status.completed());
  REQUIRE(run.jumps.size() == 9);
  const NoisyFit fit = FitNoisy(model, run, 0.01, 4);
  CHECK(fit.recursive.jumps_detected < 9);
  const RefineResult& r = fit.r;
  INFO(ToString(r.status) << ": " << r.reason);
  CHECK(r.status == RefineStatus::kSingularFisher);
  CHECK(r.route == "multiple shooting by time");
  REQUIRE(r.names == std::vector<std::string>{"k", "delta", "h_low", "x0[h]"});
  const Vec& se = r.determined_standard_errors;
  REQUIRE(se.size() == 4);
  CHECK(std::isnan(se[1]));
  CHECK(std::isnan(se[2]));
  const Vec theta = r.refined.Theta(r.unknowns);
  CHECK(std::abs(theta[0] - 0.3) < 4.0 * se[0]);
  CHECK(std::abs(theta[3] - 2.0) < 4.0 * se[3]);
  // At the bound with h_low held known (the data's information at the refined point).
  const Crlb at = ComputeCrlb(model, r.refined, grid, r.sigma, r.unknowns);
  const Crlb held = CrlbFromFisher(at.fisher, r.unknowns, r.names, {2});
  REQUIRE(held.ok());
  CHECK(se[0] == Approx(held.sd[0]).epsilon(0.25));
  CHECK(se[3] == Approx(held.sd[3]).epsilon(0.25));
}

}  // namespace
}  // namespace hysid
