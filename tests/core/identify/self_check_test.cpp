// The recursive path checks itself (core/identify/self_check.hpp): a flow estimate whose residuals
// contradict the data's noise, or a detector that found no jump in data that jump, is not ok; a right
// fit on data from the model itself stays ok.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/builtin/impact_msd.hpp"
#include "core/identify/identifier.hpp"
#include "core/identify/metrics.hpp"
#include "core/identify/self_check.hpp"
#include "core/model_file/model_file.hpp"
#include "sim/measurement.hpp"
#include "sim/simulator.hpp"
#include "tests/testing/vec.hpp"

namespace hysid {
namespace {

using testing::V;

// examples/drag-ball with both states measured: h' = v, v' = −g − k v|v|, v+ = −e v at h = 0.
constexpr const char* kDragBall = R"toml(
name = "drag-ball"
states = ["h", "v"]
alpha = [
  { name = "alpha_h", value = 1.0, known = true },
  { name = "g", value = 9.81 },
  { name = "k", value = 0.05 },
]
beta = [
  { name = "beta_h", value = 1.0, known = true },
  { name = "e", value = 0.85 },
]
[flow]
phi = [["v", 0, 0], [0, -1, "-v*abs(v)"]]
rows = ["v"]
[jump]
psi = [["h", 0], [0, "-v"]]
rows = ["v"]
[[guard]]
name = "floor"
h = "h"
direction = "falling"
project = { h = "0" }
[sets]
C = "h > 0 || (h == 0 && v >= 0)"
D = "h == 0 && v <= 0"
[defaults]
x0 = [2.0, 0.0]
t_end = 5.0
dt = 0.006666666666666667
)toml";

}  // namespace

TEST_CASE(
    "drag ball, both states measured: the paper detector finds at most one bounce, g is far off - the flow "
    "estimate is inconsistent, not ok - the residual detector's right fit stays ok",
    "[identify][self_check]") {
  const Model model = ParseModelFile(kDragBall, "drag-ball.toml").model;
  const SampleGrid grid{5.0, 1.0 / 150.0};
  const Trajectory truth = Simulate(model, V(2.0, 0.0), grid);
  REQUIRE(truth.status.completed());
  const long bounces = CompareJumps(truth.j, std::vector<std::uint8_t>(truth.j.size(), 0)).fn;
  REQUIRE(bounces >= 8);
  for (const unsigned seed : {1u, 2u, 3u}) {
    INFO("seed " << seed);
    const Mat y = AddMeasurementNoise(truth.x, Vec::Constant(2, 1e-3), NoiseKey{.seed = seed, .stream = 0});
    IdentifierSettings paper;  // the defaults: rls, the paper detector
    paper.sets = false;
    const IdentifyResult r = Identify(model, y, grid.dt, paper);
    INFO("paper: jumps " << r.jumps_detected << ", alpha " << r.alpha_hat.transpose() << ", flow "
                         << ToString(r.flow_status) << ": " << r.flow_reason);
    // The case itself: at most one of the bounces found, g off by far more than 50 %.
    CHECK(CompareJumps(truth.j, r.gamma).tp <= 1);
    CHECK(std::abs(r.alpha_hat[1] - 9.81) > 0.5 * 9.81);
    // Not ok, with the reason naming the state row and the noise.
    CHECK(r.flow_status == EstimatorStatus::kInconsistent);
    CHECK_THAT(r.flow_reason, Catch::Contains("of v ") && Catch::Contains("noise"));

    IdentifierSettings residual = paper;
    residual.detector.kind = DetectorKind::kResidual;
    const IdentifyResult good = Identify(model, y, grid.dt, residual);
    INFO("residual: jumps " << good.jumps_detected << ", alpha " << good.alpha_hat.transpose() << ", flow "
                            << ToString(good.flow_status) << ": " << good.flow_reason);
    CHECK(CompareJumps(truth.j, good.gamma).tp >= bounces - 1);
    CHECK(std::abs(good.alpha_hat[1] - 9.81) < 0.05 * 9.81);
    CHECK(good.flow_status == EstimatorStatus::kOk);
  }
}

TEST_CASE(
    "§5 with noise: no false refusal over 20 draws - noise-free with a detector that misses every "
    "jump: not ok, the data jump where nothing was detected",
    "[identify][self_check]") {
  const Model model{ImpactMsd{}};
  const Trajectory truth = Simulate(model, DefaultState(model), SampleGrid{20.0, 5e-4});
  REQUIRE(truth.status.completed());
  IdentifierSettings settings;  // paper defaults
  settings.sets = false;
  int ok = 0;
  for (unsigned seed = 1; seed <= 20; ++seed) {
    const Mat y = AddMeasurementNoise(truth.x, Vec::Constant(2, 0.01), NoiseKey{.seed = seed, .stream = 0});
    const IdentifyResult r = Identify(model, y, truth.dt, settings);
    INFO("seed " << seed << ": " << ToString(r.flow_status) << " " << r.flow_reason);
    CHECK(r.flow_status == EstimatorStatus::kOk);
    ok += r.flow_status == EstimatorStatus::kOk ? 1 : 0;
  }
  CHECK(ok == 20);
  // Noise-free, the right detections: ok (σ̂ of noise-free samples is their smooth part; the floor
  // keeps rounding from counting).
  CHECK(Identify(model, truth.x, truth.dt, settings).flow_status == EstimatorStatus::kOk);
  // r = 1000: D/τ̂ at a jump ≈ 0.8 < 1, so every jump is missed (tests/core/identify/identifier_test.cpp).
  settings.detector.r = 1000.0;
  const IdentifyResult missed = Identify(model, truth.x, truth.dt, settings);
  REQUIRE(missed.jumps_detected == 0);
  INFO(missed.flow_reason);
  CHECK(missed.flow_status == EstimatorStatus::kInconsistent);
  CHECK_THAT(missed.flow_reason, Catch::Contains("of v "));
  // Given labels: the caller classified the samples, no verdict.
  IdentifyOptions labelled;
  labelled.labels.assign(truth.j.size(), 0);
  CHECK(Identify(model, truth.x, truth.dt, settings, labelled).flow_status == EstimatorStatus::kOk);
  // And the check can be turned off.
  IdentifyOptions unchecked;
  unchecked.check_residuals = false;
  CHECK(Identify(model, truth.x, truth.dt, settings, unchecked).flow_status == EstimatorStatus::kOk);
}

TEST_CASE(
    "one step in v that no detector sees: the residuals' RMS is within the noise, the largest residual "
    "is not - not ok, naming its time",
    "[identify][self_check]") {
  const Model model{ImpactMsd{}};
  // §5 before its first impact (t ≈ 0.70 s): 1201 samples of flow, σ = 0.01.
  const Trajectory truth = Simulate(model, DefaultState(model), SampleGrid{0.6, 5e-4});
  REQUIRE(truth.status.completed());
  REQUIRE(truth.jumps.empty());
  Mat y = AddMeasurementNoise(truth.x, Vec::Constant(2, 0.01), NoiseKey{.seed = 4, .stream = 0});
  IdentifierSettings settings;
  settings.sets = false;
  settings.detector.r = 1000.0;  // blind to jumps
  const IdentifyResult clean = Identify(model, y, truth.dt, settings);
  INFO("clean: " << ToString(clean.flow_status) << " " << clean.flow_reason);
  CHECK(clean.flow_status == EstimatorStatus::kOk);
  // A step of 0.5 in v at sample 600 (t = 0.3): 35 noise sd of Δv, one sample of 1200, so the RMS rises
  // by a factor √(1 + 35²/1200) ≈ 1.4 < 3, and the step exceeds √(2 ln K) + 3 ≈ 6.8 sd.
  y.row(1).tail(y.cols() - 600).array() += 0.5;
  const IdentifyResult stepped = Identify(model, y, truth.dt, settings);
  INFO("stepped: jumps " << stepped.jumps_detected << ", " << ToString(stepped.flow_status) << " "
                         << stepped.flow_reason);
  REQUIRE(stepped.jumps_detected == 0);
  CHECK(stepped.flow_status == EstimatorStatus::kInconsistent);
  CHECK_THAT(stepped.flow_reason, Catch::Contains("found no jump") && Catch::Contains("t = 0.3"));
}

}  // namespace hysid
