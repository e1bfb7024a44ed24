// Identification of a model with measured inputs: the flow regression's trapezoid with φ at both
// ends with their own u (closed form), the recursive estimate on noise-free data of the driven
// oscillator (a trapezoid with u at one end only would be off by O(δt)), both detectors finding its
// impacts, and the refusals that name what is missing.
#include <catch2/catch.hpp>

#include <cmath>
#include <stdexcept>

#include "core/identify/identifier.hpp"
#include "core/model/regression.hpp"
#include "core/model_file/input_defaults.hpp"
#include "core/model_file/model_file.hpp"
#include "sim/exogenous.hpp"
#include "sim/input_signal.hpp"
#include "sim/measurement.hpp"
#include "sim/simulator.hpp"

namespace hysid {
namespace {

// x' = v, v' = −k x + G u·x (an input that multiplies a state, so φ's u-column differs at both ends).
struct Pumped {
  ModelSpec Spec() const {
    ModelSpec s;
    s.name = "pumped";
    s.state_names = {"x", "v"};
    auto param = [](const char* name, double value, bool known) {
      Parameter p;
      p.name = name;
      p.value = value;
      p.known = known;
      return p;
    };
    s.alpha = {param("a", 1.0, true), param("k", 2.0, false), param("G", 0.5, false)};
    s.beta = {param("e", 0.5, false)};
    s.flow_rows = {1};
    s.jump_rows = {1};
    s.guards = {Guard{"wall", Crossing::kRising}};
    s.default_x0 = {0.0, 1.0};
    s.inputs = {"u"};
    return s;
  }
  void Phi(ConstVecRef x, const Context& c, MatRef phi) const {
    phi.setZero();
    phi(0, 0) = x[1];
    phi(1, 1) = -x[0];
    phi(1, 2) = c.u[0] * x[0];
  }
  void Psi(ConstVecRef x, const Context& c, MatRef psi) const {
    psi(0, 0) = 0.0;
    psi(1, 0) = -x[1] + c.u[0];
  }
  void Guards(ConstVecRef x, const Context&, VecRef h) const { h[0] = x[0] - 1.0; }
  bool InFlowSet(ConstVecRef x, const Context&) const { return x[0] <= 1.0; }
  bool InJumpSet(ConstVecRef x, const Context&) const { return x[0] >= 1.0; }
};

TEST_CASE("the flow regression takes phi at both samples with their own inputs", "[inputs]") {
  const Model model{Pumped{}};
  RegressionBuilder builder(model);
  const Vec prev = (Vec(2) << 0.3, -1.0).finished(), cur = (Vec(2) << 0.25, -1.2).finished();
  const double dt = 0.05, u0 = 2.0, u1 = 3.0;
  Mat phi(1, 2);
  Vec y(1);
  builder.Flow(prev, cur, dt, phi, y, Context{.t = 1.0, .u = &u0}, Context{.t = 1.05, .u = &u1});
  // Δv = (δt/2)[(−x0)k + (−x1)k] + (δt/2)[u0 x0 + u1 x1] G; no known column in row v.
  CHECK(y[0] == Approx(cur[1] - prev[1]));
  CHECK(phi(0, 0) == Approx(0.5 * dt * (-prev[0] - cur[0])));
  CHECK(phi(0, 1) == Approx(0.5 * dt * (u0 * prev[0] + u1 * cur[0])));
  Mat psi(1, 1);
  Vec yj(1);
  builder.Jump(prev, cur, psi, yj, Context{.t = 1.0, .u = &u0});
  CHECK(psi(0, 0) == Approx(-prev[1] + u0));
  CHECK(yj[0] == cur[1]);
}

struct Driven {
  Model model = ReadModelFile(HYSID_EXAMPLES_DIR "/driven-oscillator/driven-oscillator.toml").model;
  SampleGrid grid{model.spec().default_t_end, model.spec().default_dt};
  InputSignal u;
  Trajectory truth;
  Driven() {
    for (long k = 0; k < grid.size(); ++k) u.times.push_back(static_cast<double>(k) * grid.dt);
    u.values = EvaluateInputDefaults(model.spec(), u.times);
    Exogenous exo;
    exo.inputs = &u;
    truth = Simulate(model, DefaultState(model), grid, {}, exo);
  }
  std::vector<std::uint8_t> TrueLabels() const {
    std::vector<std::uint8_t> labels(truth.j.size(), 0);
    for (std::size_t k = 1; k < labels.size(); ++k) labels[k] = truth.j[k] != truth.j[k - 1] ? 1 : 0;
    return labels;
  }
};

TEST_CASE("noise-free driven oscillator: the recursive estimate of k, b, G is the trapezoid's", "[inputs]") {
  const Driven d;
  REQUIRE(d.truth.status.completed());
  REQUIRE(d.truth.jumps.size() >= 8);
  IdentifyOptions options;
  options.inputs = d.u.values;
  options.labels = d.TrueLabels();
  const IdentifyResult r = Identify(d.model, d.truth.x, d.grid.dt, IdentifierSettings{}, options);
  // Trapezoid error O(δt²) ≈ 1e-7 relative; with u at one end only G would be off by O(δt) = 1e-3.
  for (int i = 1; i < 4; ++i) CHECK(r.alpha_hat[i] == Approx(d.model.alpha()[i]).epsilon(2e-5));
  // β from the samples around each impact (not at its instant): the paper's O(δt) bias.
  CHECK(r.beta_hat[1] == Approx(d.model.beta()[1]).epsilon(0.02));
}

// The paper detector at r = 100: at its default r = 220 its bound (with f̂(0, u) up to G·1.5 = 4.5)
// passes over the grazing impact at t = 36.6 s (pre-impact speed 0.78).
TEST_CASE("both detectors find the driven oscillator's impacts and nothing else", "[inputs]") {
  const Driven d;
  const std::vector<std::uint8_t> truth = d.TrueLabels();
  const Mat y = AddMeasurementNoise(d.truth.x, Vec::Constant(2, 1e-4), NoiseKey{.seed = 3, .stream = 0});
  IdentifyOptions options;
  options.inputs = d.u.values;
  for (DetectorKind kind : {DetectorKind::kPaper, DetectorKind::kResidual}) {
    IdentifierSettings settings;
    settings.detector.kind = kind;
    settings.detector.r = 100.0;
    settings.data_rtol = settings.data_atol = 1e-12;
    const IdentifyResult r = Identify(d.model, y, d.grid.dt, settings, options);
    std::vector<std::size_t> wrong;  // samples classified otherwise than the truth
    for (std::size_t k = 0; k < truth.size(); ++k) {
      if (r.gamma[k] != truth[k]) wrong.push_back(k);
    }
    INFO(ToString(kind) << ": " << wrong.size() << " samples misclassified, the first at "
                        << (wrong.empty() ? 0 : wrong.front()));
    CHECK(wrong.empty());
    CHECK(r.flow_status == EstimatorStatus::kOk);
  }
}

TEST_CASE("a model with inputs refuses what would run without them, by name", "[inputs]") {
  const Driven d;
  const Mat y = d.truth.x.leftCols(100);
  CHECK_THROWS_WITH(
      Identify(d.model, y, d.grid.dt, IdentifierSettings{}),
      Catch::Contains("IdentifyOptions::inputs is 0 × 0; model 'driven-oscillator' has 1 inputs"));
  IdentifyOptions wrong;
  wrong.inputs = d.u.values.leftCols(99);
  CHECK_THROWS_WITH(Identify(d.model, y, d.grid.dt, IdentifierSettings{}, wrong),
                    Catch::Contains("the data 100 samples"));
  Identifier id(d.model, d.grid.dt, IdentifierSettings{});
  CHECK_THROWS_WITH(id.Step(y.col(0)), Catch::Contains("has inputs; each sample needs its context"));
  CHECK_THROWS_WITH(id.Feed(y, nullptr), Catch::Contains("has inputs"));
  IdentifierSettings gtls;
  gtls.UseEstimator(EstimatorKind::kGtls);
  CHECK_THROWS_WITH(Identifier(d.model, d.grid.dt, gtls),
                    Catch::Contains("IdentifierSettings::flow_estimator: 'gtls' needs a noise shape"));
  IdentifierSettings localize;
  localize.localize = true;
  CHECK_THROWS_WITH(Identifier(d.model, d.grid.dt, localize),
                    Catch::Contains("IdentifierSettings::localize"));
}

}  // namespace
}  // namespace hysid
