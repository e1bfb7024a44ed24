// A plant under a sampled-data controller whose held command uh is hidden: with the actuator gain b
// unknown, (b, K1, K2, uh) and (b/c, c K1, c K2, c uh) give the same measured x and v. Multiple
// shooting by time calls that fit singular-fisher and names the direction in b, K1 and K2; with b
// known the same data give an ok fit within 4 SE of the truth. (The model of bench/zoh-loop; the
// case where only the smallest eigenvalue, not a pivot, shows the singularity is the command line's
// cli.identify.unidentifiable.)
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "core/model_file/model_file.hpp"
#include "sim/input_signal.hpp"
#include "sim/measurement.hpp"
#include "sim/refine/refine.hpp"
#include "sim/refine/time_shooting.hpp"

namespace hysid {
namespace {

std::string Text(bool b_known) {
  return std::string(R"toml(
name = "zoh-loop"
states = ["x", "v", "uh", "tau"]
measured = ["x", "v"]
inputs = ["r"]
input_defaults = { r = "sin(0.5*t) + 0.5*sin(1.3*t)" }
alpha = [ { name = "one", value = 1.0, known = true }, { name = "a", value = 0.8 },
          { name = "b", value = 2.0)toml") +
         (b_known ? ", known = true" : "") + R"toml( } ]
beta = [ { name = "keep", value = 1.0, known = true }, { name = "K1", value = 1.5 }, { name = "K2", value = 0.6 } ]
guard_params = [ { name = "T", value = 0.25, bounds = [0.05, 2.0] } ]
[flow]
phi = [["v", 0, 0], [0, "-v", "uh"], [0, 0, 0], [1, 0, 0]]
rows = ["v"]
[jump]
psi = [["x", 0, 0], ["v", 0, 0], [0, "r - x", "-v"], [0, 0, 0]]
rows = ["uh"]
[[guard]]
name = "tick"
h = "tau - T"
direction = "rising"
[sets]
C = "tau <= T"
D = "tau >= T"
[defaults]
x0 = [0.5, 0.0, 0.0, 0.1]
t_end = 30.0
dt = 0.02
)toml";
}

const Vec kX0 = (Vec(4) << 0.5, 0.0, 0.0, 0.1).finished();

// The model's own run with σ = 0.01 on x and v, fit by time shooting from the truth; uh and tau
// start from the model's own run (their reconstruction's place).
RefineResult FitFromTruth(const Model& model) {
  const SampleGrid grid{30.0, 0.02};
  InputSignal inputs;
  inputs.values.resize(1, 1501);
  for (long k = 0; k < 1501; ++k) {
    const double t = 0.02 * static_cast<double>(k);
    inputs.times.push_back(t);
    inputs.values(0, k) = std::sin(0.5 * t) + 0.5 * std::sin(1.3 * t);
  }
  const Trajectory truth = Simulate(model, kX0, grid, {}, Exogenous{.gamma = Vec(), .inputs = &inputs});
  REQUIRE(truth.jumps.size() >= 100);
  REQUIRE(truth.size() == 1501);
  Mat y = AddMeasurementNoise(truth.x, Vec::Constant(4, 0.01), NoiseKey{.seed = 4, .stream = 0});
  y.row(2) = truth.x.row(2);
  y.row(3) = truth.x.row(3);
  const RefineChain chain =
      RefineChain::Of(inputs.times, std::move(y), std::vector<std::uint8_t>(1501, 0), inputs.values);
  RefineOptions options;
  options.measured = {0, 1};
  return FitByTimeShooting(model, {chain}, HybridParameters::Of(model, kX0), options);
}

TEST_CASE("a hidden state's scale against the gains that read it is singular-fisher, named",
          "[time_shooting]") {
  const Model model = ParseModelFile(Text(false), "zoh-loop.toml").model;
  const RefineResult fit = FitFromTruth(model);
  INFO(fit.reason);
  CHECK(fit.status == RefineStatus::kSingularFisher);
  for (const char* name : {" b", " K1", " K2"}) CHECK(fit.reason.find(name) != std::string::npos);
}

TEST_CASE("the same model with the gain known is ok within 4 SE", "[time_shooting]") {
  const Model model = ParseModelFile(Text(true), "zoh-loop-known-b.toml").model;
  const RefineResult fit = FitFromTruth(model);
  INFO(fit.reason);
  REQUIRE(fit.ok());
  const Vec theta = fit.estimate.Theta(fit.unknowns),
            want = HybridParameters::Of(model, kX0).Theta(fit.unknowns);
  for (Eigen::Index i = 0; i < fit.unknowns.shared(); ++i) {
    CAPTURE(i, theta[i], want[i], fit.standard_errors[i]);
    CHECK(std::abs(theta[i] - want[i]) < 4 * fit.standard_errors[i]);
  }
}

}  // namespace
}  // namespace hysid
