// Matched mode with segments that hold no sample: two switches inside one sample interval, and a chain
// of switches at t = 0 (the initial state past a guard). Read on the model's own jump counts, the
// matched run is the plain run: the same states, sensitivities and jumps, within the integration's
// tolerance (the matched mode integrates in another order).
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "core/model_file/model_file.hpp"
#include "sim/sensitivity/sensitivity.hpp"

namespace hysid {
namespace {

// x rises at rate a in mode up and falls at rate b in mode down, between the levels 1 (rising: up ->
// down) and lo (falling: down -> up, a guard parameter). From x0 = 1.5 in mode up the state starts
// past the top: a switch at t = 0. With lo = 0.9 and a = b = 1 the switches come 0.2 apart, so a
// sample step of 0.25 has intervals with two switches in them.
constexpr const char* kSawtooth = R"(
name = "sawtooth"
states = ["x"]
modes = ["up", "down"]
alpha = [ { name = "a", value = 1.0 }, { name = "b", value = 1.0 } ]
guard_params = [ { name = "lo", value = 0.9 } ]

[[flow]]
mode = "up"
phi = [[1, 0]]

[[flow]]
mode = "down"
phi = [[0, -1]]

[[jump]]
name = "top"
guard = "top"
from = "up"
to = "down"

[[jump]]
name = "bottom"
guard = "bottom"
from = "down"
to = "up"

[[guard]]
name = "top"
h = "x - 1"
direction = "rising"

[[guard]]
name = "bottom"
h = "x - lo"
direction = "falling"

[defaults]
x0 = [1.5]
mode = "up"
t_end = 3.0
dt = 0.25
)";

TEST_CASE("matched mode reads segments without samples as the plain run does", "[sensitivity]") {
  const Model model = ParseModelFile(kSawtooth, "sawtooth.toml").model;
  const Unknowns u = Unknowns::Of(model);
  HybridParameters p = HybridParameters::Of(model, (Vec(1) << 1.5).finished());
  p.initial_mode = 0;
  const SampleGrid grid{3.0, 0.25};
  SensitivityOptions o;
  o.sim.rtol = o.sim.atol = 1e-12;
  const SensitivityTrajectory plain = SimulateSensitivities(model, p, u, grid, o);
  REQUIRE(plain.ok());
  const std::vector<int>& labels = plain.trajectory.j;
  // The switch at t = 0 labels the first sample 1; some interval holds two switches.
  REQUIRE(labels.front() == 1);
  bool two_in_one = false;
  for (std::size_t k = 1; k < labels.size(); ++k) two_in_one = two_in_one || labels[k] - labels[k - 1] == 2;
  REQUIRE(two_in_one);

  const SensitivityTrajectory matched = SimulateSensitivitiesMatched(model, p, u, grid, labels, o);
  INFO(matched.trajectory.status.message);
  REQUIRE(matched.ok());
  CHECK(matched.extra_jumps == 0);
  REQUIRE(matched.trajectory.jumps.size() == plain.trajectory.jumps.size());
  for (std::size_t j = 0; j < plain.trajectory.jumps.size(); ++j) {
    CHECK(matched.trajectory.jumps[j].t == Approx(plain.trajectory.jumps[j].t).margin(1e-9));
    CHECK(matched.trajectory.jumps[j].map == plain.trajectory.jumps[j].map);
  }
  CHECK(matched.trajectory.j == labels);
  CHECK((matched.trajectory.x - plain.trajectory.x).cwiseAbs().maxCoeff() < 1e-9);
  CHECK((matched.sensitivities - plain.sensitivities).cwiseAbs().maxCoeff() < 1e-8);
}

TEST_CASE("matched mode refuses labels that decrease", "[sensitivity]") {
  const Model model = ParseModelFile(kSawtooth, "sawtooth.toml").model;
  HybridParameters p = HybridParameters::Of(model, (Vec(1) << 1.5).finished());
  std::vector<int> labels(13, 1);
  labels[6] = 0;
  CHECK_THROWS_WITH(SimulateSensitivitiesMatched(model, p, Unknowns::Of(model), SampleGrid{3.0, 0.25}, labels),
                    Catch::Contains("segment_of_sample[6] = 0 after 1"));
}

}  // namespace
}  // namespace hysid
