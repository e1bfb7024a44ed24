// Model files of hybrid automata: the issue's two texts load as written; φ per mode and ψ per map
// evaluate to the hand-computed matrices; the jump maps carry their guard, modes and β slices; the
// example files load; every bad combination is refused naming the file, the line and the key.
#include <catch2/catch.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

#include "core/io/files.hpp"
#include "core/model/automaton.hpp"
#include "core/model_file/model_file.hpp"

namespace hysid {
namespace {

// The issue's first text (two jump maps), completed into a file: states, α, guards, defaults.
const std::string kTwoMaps = R"toml(name = "two-walls"
states = ["h", "v"]
alpha = [ { name = "one", value = 1.0, known = true }, { name = "g", value = 9.81 } ]
[flow]
phi = [["v", 0], [0, -1]]
rows = ["v"]
# several jump maps: each [[jump]] names the guard that triggers it and has its own β
[[jump]]
name = "floor"
guard = "floor"
beta = [ { name = "one_f", value = 1.0, known = true }, { name = "e_floor", value = 0.8 } ]
psi = [["h", 0], [0, "-v"]]
rows = ["v"]
[[jump]]
name = "ceiling"
guard = "ceiling"
beta = [ { name = "one_c", value = 1.0, known = true }, { name = "e_ceiling", value = 0.5 } ]
psi = [["h", 0], [0, "-v"]]
rows = ["v"]
[[guard]]
name = "floor"
h = "h"
direction = "falling"
[[guard]]
name = "ceiling"
h = "h - 2"
direction = "rising"
[defaults]
x0 = [1.0, 9.0]
t_end = 3.0
dt = 1e-3
)toml";

// The issue's second text, exactly as written.
const std::string kPumpTank = R"toml(# flow modes: a discrete mode q (measured or not), φ per mode, jumps that switch mode; a jump without
# psi is the identity; guard_params as in the issue on measured systems
name = "pump-tank"
states = ["h"]
modes = ["off", "on"]
alpha = [ { name = "a", value = 0.5 }, { name = "P", value = 1.0 } ]
guard_params = [ { name = "h_lo", value = 1.0 }, { name = "h_hi", value = 2.0 } ]
[[flow]]
mode = "off"
phi = [["-sqrt(h)", 0]]
[[flow]]
mode = "on"
phi = [["-sqrt(h)", 1]]
[[jump]]
name = "pump-on"
from = "off"
to = "on"
guard = "low"
[[jump]]
name = "pump-off"
from = "on"
to = "off"
guard = "high"
[[guard]]
name = "low"
h = "h - h_lo"
direction = "falling"
[[guard]]
name = "high"
h = "h - h_hi"
direction = "rising"
[defaults]
x0 = [1.5]
mode = "on"
)toml";

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  REQUIRE(at != std::string::npos);
  return text.replace(at, from.size(), to);
}

std::string ErrorOf(const std::string& text) {
  try {
    ParseModelFile(text, "m.toml");
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(loaded)";
}

Vec State(std::initializer_list<double> v) {
  Vec x(static_cast<Eigen::Index>(v.size()));
  Eigen::Index i = 0;
  for (double e : v) x[i++] = e;
  return x;
}

TEST_CASE("the issue's two-map text: ψ per map in its own β slice, the maps' fields", "[model_file]") {
  const Model model = ParseModelFile(kTwoMaps, "two-walls.toml").model;
  const ModelSpec& s = model.spec();
  REQUIRE(s.beta.size() == 4);
  REQUIRE(s.beta[1].name == "e_floor");
  REQUIRE(s.beta[3].name == "e_ceiling");
  REQUIRE(s.beta[0].known);
  REQUIRE(s.jumps.size() == 2);
  const JumpMap& floor = s.jumps[0];
  const JumpMap& ceiling = s.jumps[1];
  REQUIRE((floor.name == "floor" && floor.guard == 0 && floor.from == -1 && floor.to == -1));
  REQUIRE((floor.beta_first == 0 && floor.beta_count == 2 && floor.rows == std::vector<int>{1} && !floor.identity));
  REQUIRE((ceiling.name == "ceiling" && ceiling.guard == 1 && ceiling.beta_first == 2 && ceiling.beta_count == 2));
  REQUIRE(s.jump_rows == std::vector<int>{1});
  REQUIRE(ArmedMap(s, 0, 0) == 0);
  REQUIRE(ArmedMap(s, 0, 1) == 1);

  // At ξ = (0.3, −2): ψ_floor = [[0.3, 0], [0, 2]] in columns 0–1, ψ_ceiling the same in columns 2–3.
  const Vec x = State({0.3, -2.0});
  Mat psi(2, 4);
  Mat floor_psi(2, 4), ceiling_psi(2, 4);
  floor_psi << 0.3, 0, 0, 0, 0, 2, 0, 0;
  ceiling_psi << 0, 0, 0.3, 0, 0, 0, 0, 2;
  model.Psi(x, psi, Context{.map = 0});
  REQUIRE(psi == floor_psi);
  model.Psi(x, psi, Context{.map = 1});
  REQUIRE(psi == ceiling_psi);
  // ξ+ = ψ_m(ξ)β: v+ = −0.8 v at the floor, −0.5 v at the ceiling.
  Vec post(2);
  model.Jump(x, model.beta(), post, Context{.map = 0});
  REQUIRE(post == State({0.3, 1.6}));
  model.Jump(x, model.beta(), post, Context{.map = 1});
  REQUIRE(post == State({0.3, 1.0}));
  // No [sets] in an automaton: C is every state, D is empty.
  REQUIRE(model.InFlowSet(State({-5.0, 1.0}), Context{}));
  REQUIRE_FALSE(model.InJumpSet(State({0.0, -1.0}), Context{}));
}

TEST_CASE("the issue's pump-tank text: φ per mode, identity maps, guard parameters, the default mode",
          "[model_file]") {
  const Model model = ParseModelFile(kPumpTank, "pump-tank.toml").model;
  const ModelSpec& s = model.spec();
  REQUIRE(s.modes == std::vector<std::string>{"off", "on"});
  REQUIRE(s.default_mode == 1);
  REQUIRE(s.beta.empty());
  REQUIRE(s.flow_rows == std::vector<int>{0});  // rows left out: the rows with an unknown α
  REQUIRE(s.jump_rows.empty());
  REQUIRE(s.default_t_end == 10.0);  // t_end and dt left out: ModelSpec's defaults
  REQUIRE(s.default_dt == 1e-3);
  REQUIRE(s.jumps.size() == 2);
  const JumpMap& on = s.jumps[0];
  REQUIRE((on.name == "pump-on" && on.guard == 0 && on.from == 0 && on.to == 1 && on.identity));
  REQUIRE((on.beta_count == 0 && on.rows.empty()));
  REQUIRE((s.jumps[1].guard == 1 && s.jumps[1].from == 1 && s.jumps[1].to == 0 && s.jumps[1].identity));
  // Only the guard of the map leaving the mode is armed.
  REQUIRE(ArmedMap(s, 0, 0) == 0);
  REQUIRE(ArmedMap(s, 0, 1) == -1);
  REQUIRE(ArmedMap(s, 1, 1) == 1);
  REQUIRE(ModeAfter(s, 0, 0) == 1);

  // At h = 4: φ_off = [−2, 0], φ_on = [−2, 1]; the flow h' = −a√h (+ P).
  const Vec x = State({4.0});
  Mat phi(1, 2);
  model.Phi(x, phi, Context{.mode = 0});
  REQUIRE((phi(0, 0) == -2.0 && phi(0, 1) == 0.0));
  model.Phi(x, phi, Context{.mode = 1});
  REQUIRE((phi(0, 0) == -2.0 && phi(0, 1) == 1.0));
  Vec dx(1);
  model.Flow(x, model.alpha(), dx, Context{.mode = 1});
  REQUIRE(dx[0] == -1.0 + 1.0);
  // The bulk path gives the same per mode.
  const Vec xs = State({4.0, 9.0});
  Mat cols(2, 2);  // two 1 × 2 blocks, column-major each
  model.PhiColumns(xs.data(), 2, cols.data(), Context{.mode = 0});
  REQUIRE((cols(0, 0) == -2.0 && cols(1, 0) == 0.0 && cols(0, 1) == -3.0 && cols(1, 1) == 0.0));
  // Guards at the context's γ; an identity map leaves ξ as it was.
  Vec h(2);
  const double gamma[] = {0.5, 3.5};
  model.Guards(x, h, Context{.gamma = gamma});
  REQUIRE((h[0] == 3.5 && h[1] == 0.5));
  Vec post(1);
  model.Jump(x, model.beta(), post, Context{.map = 0});
  REQUIRE(post[0] == 4.0);
  REQUIRE_THAT(s.equations, Catch::Matchers::Contains("flow [on]: h' = a*(-sqrt(h)) + P\n"));
  REQUIRE_THAT(s.equations, Catch::Matchers::Contains("jump pump-on (guard low, off -> on): identity"));
  REQUIRE_THAT(s.equations, Catch::Matchers::Contains("modes: off, on (default on)"));
}

TEST_CASE("the examples' model files load with their automata", "[model_file]") {
  const std::string dir = HYSID_EXAMPLES_DIR;
  const ModelSpec fc = ReadModelFile(dir + "/floor-ceiling/model.toml").model.spec();
  REQUIRE((fc.jumps.size() == 2 && fc.modes.empty() && fc.beta.size() == 4));
  const ModelSpec pump = ReadModelFile(dir + "/pump-tank/model.toml").model.spec();
  REQUIRE((pump.modes.size() == 2 && pump.guard_params.size() == 2 && pump.default_mode == 1));
  const Model heater = ReadModelFile(dir + "/heater/model.toml").model;
  const ModelSpec& hs = heater.spec();
  REQUIRE((hs.modes.size() == 3 && hs.jumps.size() == 3 && hs.default_mode == 0));
  // T' = −kT + P_q: at T = 20, φ_q = [−20, [q = low], [q = high]].
  Mat phi(1, 3);
  for (int q = 0; q < 3; ++q) {
    heater.Phi(State({20.0}), phi, Context{.mode = q});
    REQUIRE((phi(0, 0) == -20.0 && phi(0, 1) == (q == 1 ? 1.0 : 0.0) && phi(0, 2) == (q == 2 ? 1.0 : 0.0)));
  }
  // Each switch leaves the mode that the previous one entered: off → high → low → off.
  REQUIRE((ModeAfter(hs, 0, ArmedMap(hs, 0, 0)) == 2 && ModeAfter(hs, 2, ArmedMap(hs, 2, 1)) == 1 &&
           ModeAfter(hs, 1, ArmedMap(hs, 1, 2)) == 0));
}

TEST_CASE("bad automata are refused naming file, line and key", "[model_file]") {
  using Catch::Matchers::Contains;
  CHECK_THAT(ErrorOf(Replace(kPumpTank, "from = \"off\"", "from = \"idle\"")),
               Contains("m.toml:16: jump[0].from: unknown mode 'idle' (known: off, on)"));
  CHECK_THAT(ErrorOf(Replace(kPumpTank, "to = \"off\"", "to = \"idle\"")),
               Contains("m.toml:22: jump[1].to: unknown mode 'idle'"));
  CHECK_THAT(ErrorOf(Replace(kPumpTank, "x0 = [1.5]\nmode = \"on\"", "x0 = [1.5]\nmode = \"idle\"")),
               Contains("m.toml:34: defaults.mode: unknown mode 'idle'"));
  CHECK_THAT(ErrorOf(Replace(kPumpTank, "guard = \"low\"", "guard = \"lowest\"")),
               Contains("m.toml:18: jump[0].guard: unknown guard 'lowest' (known: low, high)"));
  CHECK_THAT(ErrorOf(Replace(kPumpTank, "guard = \"high\"", "guard = \"low\"")),
               Contains("m.toml:28: guard[1]: guard 'high' triggers no [[jump]] map"));
  CHECK_THAT(ErrorOf(Replace(kTwoMaps, "guard = \"ceiling\"", "guard = \"floor\"")),
               Contains("m.toml:16: jump[1].guard: guard 'floor' already triggers map 'floor'"));
  CHECK_THAT(ErrorOf(Replace(kTwoMaps, "beta = [ { name = \"one_c\", value = 1.0, known = true }, "
                                         "{ name = \"e_ceiling\", value = 0.5 } ]\n", "")),
               Contains("m.toml:17: jump[1].psi: psi needs the map's own parameters: give beta"));
  CHECK_THAT(ErrorOf(Replace(kPumpTank, "guard = \"low\"", "guard = \"low\"\nrows = [\"h\"]")),
               Contains("m.toml:19: jump[0].rows: an identity map"));
  CHECK_THAT(ErrorOf(Replace(kPumpTank, "guard = \"low\"", "guard = \"low\"\nbeta = [{ name = \"b\", value = 1 }]")),
               Contains("m.toml:19: jump[0].beta: an identity map"));
  CHECK_THAT(ErrorOf(Replace(kPumpTank, "name = \"pump-off\"", "name = \"pump-on\"")),
               Contains("m.toml:20: jump[1].name: jump map name 'pump-on' appears twice"));
  CHECK_THAT(ErrorOf(Replace(kPumpTank, "[\"off\", \"on\"]", "[\"off\", \"on\", \"off\"]")),
               Contains("m.toml:5: modes[2]: 'off' appears twice"));
  CHECK_THAT(ErrorOf(Replace(kPumpTank, "mode = \"on\"\nphi", "mode = \"off\"\nphi")),
               Contains("m.toml:12: flow[1].mode: a [[flow]] for mode 'off' appears twice"));
  CHECK_THAT(ErrorOf(Replace(kPumpTank, "[\"off\", \"on\"]", "[\"off\", \"on\", \"boost\"]")),
               Contains("m.toml:5: modes: mode 'boost' has no [[flow]] table"));
  CHECK_THAT(ErrorOf(Replace(kTwoMaps, "[flow]", "[[flow]]\nmode = \"x\"\n[flow]")), Contains("m.toml:"));
  CHECK_THAT(ErrorOf(Replace(kTwoMaps, "[flow]", "[[flow]]\nmode = \"x\"\n[[flow]]")),
               Contains("m.toml:4: flow: [[flow]] tables need modes"));
  CHECK_THAT(ErrorOf(Replace(kPumpTank, "[[flow]]\nmode = \"off\"\nphi = [[\"-sqrt(h)\", 0]]\n[[flow]]\nmode = \"on\"\n", "[flow]\n")),
               Contains("m.toml:8: flow: with modes = [...], give one [[flow]] table per mode"));
  CHECK_THAT(ErrorOf(Replace(kTwoMaps, "[[guard]]\nname = \"floor\"", "[[guard]]\nname = \"ceiling\"")),
               Contains("guard[1].name: guard name 'ceiling' (jump maps name their guard) appears twice"));
  CHECK_THAT(ErrorOf(Replace(kTwoMaps, "guard = \"floor\"", "guard = \"floor\"\nfrom = \"a\"")),
               Contains("m.toml:11: jump[0].from: names a mode, but the file has no modes"));
  CHECK_THAT(ErrorOf(Replace(kTwoMaps, "name = \"e_ceiling\"", "name = \"e_floor\"")),
               Contains("jump[1].beta[1].name: 'e_floor' is already the name of a parameter"));
  CHECK_THAT(ErrorOf(Replace(kTwoMaps, "states = [\"h\", \"v\"]", "states = [\"h\", \"v\"]\nbeta = []")),
               Contains("m.toml:3: beta: with [[jump]] maps each map has its own beta"));
  CHECK_THAT(ErrorOf(Replace(kTwoMaps, "x0 = [1.0, 9.0]", "x0 = [1.0, 9.0]\nmode = \"up\"")),
               Contains("m.toml:30: defaults.mode: names a mode, but the file has no modes"));
}

// kTwoMaps with two flow modes of the same φ: the [[flow]] tables give `up_rows` and `down_rows`.
std::string TwoModes(const std::string& up_rows, const std::string& down_rows) {
  return Replace(Replace(kTwoMaps, "states = [\"h\", \"v\"]", "states = [\"h\", \"v\"]\nmodes = [\"up\", \"down\"]"),
                 "[flow]\nphi = [[\"v\", 0], [0, -1]]\nrows = [\"v\"]\n",
                 "[[flow]]\nmode = \"up\"\nphi = [[\"v\", 0], [0, -1]]\nrows = " + up_rows +
                     "\n[[flow]]\nmode = \"down\"\nphi = [[\"v\", 0], [0, -1]]\nrows = " + down_rows + "\n");
}

TEST_CASE("the rows of [[flow]] and [[jump]] tables have the checks of [flow] and [jump]", "[model_file]") {
  using Catch::Matchers::Contains;
  // The jump maps' rows: a state named, each once, every unknown β of the map in a row.
  const std::string jump0 = "psi = [[\"h\", 0], [0, \"-v\"]]\nrows = [\"v\"]";
  CHECK_THAT(ErrorOf(Replace(kTwoMaps, jump0, "psi = [[\"h\", 0], [0, \"-v\"]]\nrows = [\"z\"]")),
             Contains("m.toml:13: jump[0].rows[0]: unknown state 'z' (known: h, v)"));
  CHECK_THAT(ErrorOf(Replace(kTwoMaps, jump0, "psi = [[\"h\", 0], [0, \"-v\"]]\nrows = [\"v\", \"v\"]")),
             Contains("m.toml:13: jump[0].rows[1]: 'v' appears twice"));
  CHECK_THAT(ErrorOf(Replace(kTwoMaps, jump0, "psi = [[\"h\", 0], [0, \"-v\"]]\nrows = [\"h\"]")),
             Contains("m.toml:13: jump[0].rows: the unknown parameter 'e_floor' enters none of the rows (h), only v"));
  // The modes' rows, where a [[flow]] gives them.
  const ModelFile two = ParseModelFile(TwoModes("[\"v\"]", "[\"v\"]"), "m.toml");
  REQUIRE(two.model.spec().flow_rows == std::vector<int>{1});
  CHECK_THAT(ErrorOf(TwoModes("[\"v\"]", "[\"q\"]")), Contains("m.toml:12: flow[1].rows[0]: unknown state 'q' (known: h, v)"));
  CHECK_THAT(ErrorOf(TwoModes("[\"v\", \"v\"]", "[\"v\"]")), Contains("m.toml:8: flow[0].rows[1]: 'v' appears twice"));
  CHECK_THAT(ErrorOf(TwoModes("[\"v\"]", "[\"h\"]")),
             Contains("m.toml:12: flow[1].rows: the unknown parameter 'g' enters none of the rows (h), only v"));
}

}  // namespace
}  // namespace hysid
