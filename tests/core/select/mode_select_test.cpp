// Selection among candidate terms per mode of a hybrid automaton (core/select/select.hpp: FlowSamples
// with modes, ColumnsInUse, KeepColumns): a spring-mass hopper whose v' has 20 candidate terms in each
// of its modes (flight with air drag: v' = -g - c|v|v; stance: v' = (w2 L0 - g) - w2 y) gives each mode
// its own support on that mode's samples; the columns of the other mode's candidates are exactly zero
// there. The drag makes each hop lower than the last: without losses every stance follows one orbit,
// on which y is nearly a function of v^2 and other supports fit as well as the true one.
#include <catch2/catch.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "core/model_file/model_file.hpp"
#include "core/select/select.hpp"
#include "sim/measurement.hpp"
#include "sim/simulator.hpp"
#include "tests/testing/vec.hpp"

namespace hysid {
namespace {

using testing::V;

constexpr const char* kHopperTail = R"toml(
[[jump]]
name = "touchdown"
from = "flight"
to = "stance"
guard = "touch"
[[jump]]
name = "lift-off"
from = "stance"
to = "flight"
guard = "lift"
[[guard]]
name = "touch"
h = "y - L0"
direction = "falling"
[[guard]]
name = "lift"
h = "y - L0"
direction = "rising"
[defaults]
x0 = [1.5, 0.0]
mode = "flight"
t_end = 10.0
dt = 1e-3
)toml";

std::string HopperTruth() {
  return std::string(R"toml(
name = "hopper"
states = ["y", "v"]
modes = ["flight", "stance"]
alpha = [ { name = "one", value = 1.0, known = true }, { name = "g", value = 9.81 }, { name = "w2", value = 400.0 },
          { name = "c", value = 0.1 } ]
guard_params = [ { name = "L0", value = 1.0 } ]
[[flow]]
mode = "flight"
phi = [["v", 0, 0, 0], [0, -1, 0, "-abs(v)*v"]]
rows = ["v"]
[[flow]]
mode = "stance"
phi = [["v", 0, 0, 0], [0, -1, "L0 - y", 0]]
rows = ["v"]
)toml") + kHopperTail;
}

constexpr const char* kTerms = R"t(["1", "y", "v", "y^2", "y*v", "v^2", "y^3", "y^2*v", "y*v^2", "v^3",
  "abs(v)*v", "abs(v)", "sign(v)", "y*abs(v)", "y*sign(v)", "y*abs(v)*v", "abs(v)*v^2", "sin(y)", "cos(y)", "exp(-y)"])t";

std::string HopperLibrary() {
  return std::string(R"toml(
name = "hopper-library"
states = ["y", "v"]
modes = ["flight", "stance"]
alpha = [ { name = "one", value = 1.0, known = true } ]
guard_params = [ { name = "L0", value = 1.0 } ]
[[flow]]
mode = "flight"
phi = [["v"], [0]]
rows = ["v"]
candidates = { v = )toml") + kTerms + R"toml( }
[[flow]]
mode = "stance"
phi = [["v"], [0]]
rows = ["v"]
candidates = { v = )toml" + kTerms + " }\n" + kHopperTail;
}

struct Data {
  Mat y;
  std::vector<std::uint8_t> gamma;
  std::vector<int> modes;
};

Data Simulated(double sigma, std::uint64_t seed) {
  const Model truth = ParseModelFile(HopperTruth(), "truth.toml").model;
  const Trajectory traj = Simulate(truth, V(1.5, 0.0), SampleGrid{10.0, 1e-3});
  REQUIRE(traj.status.completed());
  return {AddMeasurementNoise(traj.x, Vec::Constant(2, sigma), NoiseKey{.seed = seed, .stream = 0}),
          std::vector<std::uint8_t>(traj.t.size(), 0), traj.q};
}

// The chosen candidates' terms, by name.
std::vector<std::string> Chosen(const Model& library, const FlowSums& sums, const Selection& s) {
  std::vector<std::string> out;
  for (std::size_t j = 0; j < s.chosen.size(); ++j)
    if (s.chosen[j]) out.push_back(library.spec().alpha[std::size_t(sums.columns[j])].name);
  return out;
}

}  // namespace

TEST_CASE("a hopper with 20 candidate terms of v' per mode: each mode's support is chosen on its samples",
          "[select]") {
  const Model library = ParseModelFile(HopperLibrary(), "library.toml").model;
  REQUIRE(library.spec().candidates.size() == 40);
  CHECK(library.spec().alpha[1].name == "flight_v_1");
  CHECK(library.spec().alpha[22].name == "stance_v_2");
  CHECK(library.spec().candidates[20].mode == 1);
  const std::vector<std::vector<std::string>> truth = {{"flight_v_1", "flight_v_11"}, {"stance_v_1", "stance_v_2"}};
  for (const std::uint64_t seed : {1u, 2u}) {
    const Data d = Simulated(3e-4, seed);
    for (int q = 0; q < 2; ++q) {
      INFO("seed " << seed << ", mode " << q);
      const FlowSums all = SumFlowSegments(
          library, FlowSamples{.y = &d.y, .gamma = &d.gamma, .dt = 1e-3, .modes = &d.modes, .mode = q, .margin = 2});
      REQUIRE(all.columns.size() == 40);
      // Mode q's φ has its own 20 candidates; the other mode's columns are exactly 0 on its samples.
      const std::vector<int> used = ColumnsInUse(all);
      REQUIRE(used.size() == 20);
      CHECK(used.front() == 20 * q);
      const FlowSums sums = KeepColumns(all, used);
      REQUIRE(sums.columns.size() == 20);
      CHECK(sums.columns.front() == 1 + 20 * q);
      const Selection s = SelectTerms(sums, std::vector<bool>(20, true), SelectOptions{});
      REQUIRE(s.ok);
      CHECK(Chosen(library, sums, s) == truth[std::size_t(q)]);
      if (q == 0) CHECK(s.estimate[0] == Approx(-9.81).epsilon(0.01));
      if (q == 0) CHECK(s.estimate[10] == Approx(-0.1).epsilon(0.02));
      if (q == 1) CHECK(s.estimate[1] == Approx(-400.0).epsilon(0.02));
    }
  }
}

TEST_CASE("per-mode sums: a mode out of range, modes of the wrong size and a negative margin are refused",
          "[select]") {
  const Model library = ParseModelFile(HopperLibrary(), "library.toml").model;
  const Data d = Simulated(3e-4, 1);
  CHECK_THROWS_WITH(SumFlowSegments(library, FlowSamples{.y = &d.y, .gamma = &d.gamma, .dt = 1e-3, .mode = 2}),
                    Catch::Contains("FlowSamples::mode = 2: model 'hopper-library' has 2 mode(s)"));
  const std::vector<int> short_modes(5, 0);
  CHECK_THROWS_WITH(SumFlowSegments(library, FlowSamples{.y = &d.y, .gamma = &d.gamma, .dt = 1e-3, .modes = &short_modes}),
                    Catch::Contains("5 modes for 10001 samples"));
  CHECK_THROWS_WITH(SumFlowSegments(library, FlowSamples{.y = &d.y, .gamma = &d.gamma, .dt = 1e-3, .margin = -1}),
                    Catch::Contains("FlowSamples::margin = -1"));
  const FlowSums all = SumFlowSegments(library, FlowSamples{.y = &d.y, .gamma = &d.gamma, .dt = 1e-3, .modes = &d.modes});
  CHECK_THROWS_WITH(KeepColumns(all, {3, 2}), Catch::Contains("ascending required"));
}

}  // namespace hysid
