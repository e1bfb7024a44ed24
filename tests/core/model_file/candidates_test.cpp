// Candidate terms in a model file ([flow], per mode [[flow]], [jump] and per map [[jump]] candidates) and the chosen model
// written from them (core/model_file/chosen.hpp): each candidate is an unknown α entry ROW_K (MODE_ROW_K
// in a [[flow]]) whose φ column is its term in its row (of its mode's φ; 0 in every other mode), or in
// [jump] an unknown β entry jump_ROW_K whose ψ column is its term in its row; the chosen model keeps the
// kept candidates as plain entries, with the values given, and evaluates as the library's columns do.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "core/model/context.hpp"
#include "core/model_file/chosen.hpp"
#include "core/model_file/model_file.hpp"
#include "sim/model_check/model_check.hpp"
#include "tests/testing/vec.hpp"

namespace hysid {
namespace {

using testing::V;

constexpr const char* kHead = R"toml(
name = "lib"
states = ["x", "v"]
alpha = [ { name = "one", value = 1.0, known = true }, { name = "k", value = 2.0 } ]
beta = [ { name = "one_x", value = 1.0, known = true }, { name = "e", value = 0.9 } ]
)toml";

constexpr const char* kTail = R"toml(
[jump]
psi = [["x", 0], [0, "-v"]]
rows = ["v"]
[[guard]]
name = "wall"
h = "x"
direction = "falling"
project = { x = "0" }
[sets]
C = "x >= 0"
D = "x <= 0 && v <= 0"
[defaults]
x0 = [1.0, 0.0]
)toml";

std::string File(const std::string& flow) { return std::string(kHead) + flow + kTail; }

const std::string kFlow = R"toml(
[flow]
phi = [["v", 0], [0, "-x"]]
rows = ["v"]
candidates = { v = ["v", "abs(v)*v", 1] }
)toml";

// A pump tank with two modes; each [[flow]] is given by `off` and `on` (its phi, rows, candidates).
std::string Automaton(const std::string& off, const std::string& on, const std::string& modes = R"(["off", "on"])") {
  const std::string first = modes == R"(["off", "on"])" ? "off" : "heat-off";
  return std::string(R"toml(
name = "tank-lib"
states = ["h"]
modes = )toml") + modes + R"toml(
alpha = [ { name = "a", value = 0.5 } ]
[[flow]]
mode = ")toml" + first + "\"\n" + off + R"toml(
[[flow]]
mode = "on"
)toml" + on + R"toml(
[[jump]]
name = "pump-on"
guard = "low"
from = ")toml" + first + R"toml("
to = "on"
[[jump]]
name = "pump-off"
guard = "high"
from = "on"
to = ")toml" + first + R"toml("
[[guard]]
name = "low"
h = "h - 1"
direction = "falling"
[[guard]]
name = "high"
h = "h - 2"
direction = "rising"
[defaults]
x0 = [1.5]
mode = "on"
t_end = 5.0
dt = 1e-2
)toml";
}

const std::string kOff = "phi = [[\"-sqrt(h)\"]]\nrows = [\"h\"]\ncandidates = { h = [\"h\", \"1\"] }\n";
const std::string kOn = "phi = [[\"-sqrt(h)\"]]\nrows = [\"h\"]\ncandidates = { h = [\"1\", \"h^2\", \"sin(h)\"] }\n";

}  // namespace

TEST_CASE("candidates per mode: MODE_ROW_K entries whose column is the term in its mode's phi, 0 in the others",
          "[model_file][select]") {
  const Model m = ParseModelFile(Automaton(kOff, kOn), "tank.toml").model;
  const ModelSpec& s = m.spec();
  REQUIRE(s.alpha.size() == 6);
  CHECK(s.alpha[1].name == "off_h_1");
  CHECK(s.alpha[2].name == "off_h_2");
  CHECK(s.alpha[3].name == "on_h_1");
  CHECK(s.alpha[5].name == "on_h_3");
  REQUIRE(s.candidates.size() == 5);
  CHECK(s.candidates[0].mode == 0);
  CHECK(s.candidates[3].mode == 1);
  CHECK(s.candidates[4].term == "sin(h)");
  CHECK(s.flow_rows == std::vector<int>{0});
  CHECK_FALSE(s.flow_jacobian_constant);
  Mat phi(1, 6);
  m.Phi(V(1.44), phi, Context{.mode = 0});
  CHECK(phi(0, 0) == -1.2);
  CHECK(phi(0, 1) == 1.44);
  CHECK(phi(0, 2) == 1.0);
  CHECK(phi(0, 3) == 0.0);
  CHECK(phi(0, 5) == 0.0);
  m.Phi(V(1.44), phi, Context{.mode = 1});
  CHECK(phi(0, 0) == -1.2);
  CHECK(phi(0, 1) == 0.0);
  CHECK(phi(0, 2) == 0.0);
  CHECK(phi(0, 3) == 1.0);
  CHECK(phi(0, 4) == 1.44 * 1.44);
  CHECK(phi(0, 5) == std::sin(1.44));
}

TEST_CASE("candidates per mode: no rows, a row not the table's, a mode name that makes no name, a repeated term and a "
          "taken name are refused by key",
          "[model_file][select]") {
  auto refused = [](const std::string& text, const std::string& what) {
    CHECK_THROWS_WITH(ParseModelFile(text, "tank.toml"), Catch::Contains(what));
  };
  refused(Automaton("phi = [[\"-sqrt(h)\"]]\ncandidates = { h = [\"h\"] }\n", kOn),
          "tank.toml:9: flow[0].candidates: candidate terms need the table's identified rows: give flow[0].rows");
  refused(Automaton(kOff, "phi = [[\"-sqrt(h)\"]]\nrows = [\"h\"]\ncandidates = { x = [\"h\"] }\n"),
          "flow[1].candidates.x: unknown state 'x' (known: h)");
  refused(Automaton(kOff, "phi = [[\"-sqrt(h)\"]]\nrows = [\"h\"]\ncandidates = { h = [\"h\", \"h\"] }\n"),
          "flow[1].candidates.h[1]");
  refused(Automaton(kOff, "phi = [[\"-sqrt(h)\"]]\nrows = [\"h\"]\ncandidates = { h = [\"q\"] }\n"),
          "flow[1].candidates.h[0]");
  refused(Automaton(kOff, kOn, R"(["heat-off", "on"])"),
          "flow[0].candidates: mode 'heat-off' does not make candidate names MODE_ROW_K");
  std::string taken = Automaton(kOff, kOn);
  taken.replace(taken.find("\"a\""), 3, "\"on_h_2\"");
  refused(taken, "flow[1].candidates.h[1]: the candidate's name 'on_h_2' is already taken");
}

TEST_CASE("the chosen model per mode: kept candidates in their own mode's phi, accepted as a model file",
          "[model_file][select]") {
  const std::string text = Automaton(kOff, kOn);
  const Model lib = ParseModelFile(text, "tank.toml").model;
  const std::string chosen_text =
      ChosenModelText(text, "tank.toml", {"off_h_2", "on_h_1", "on_h_3"}, {{"a", 0.4}, {"off_h_2", -0.25}, {"on_h_1", 1.5}});
  INFO(chosen_text);
  const Model chosen = ParseModelText(chosen_text, "chosen.toml");
  const ModelSpec& s = chosen.spec();
  CHECK(s.candidates.empty());
  REQUIRE(s.alpha.size() == 4);
  CHECK(s.alpha[1].name == "off_h_2");
  CHECK(s.alpha[2].name == "on_h_1");
  CHECK(s.alpha[3].name == "on_h_3");
  CHECK(chosen.alpha()[0] == 0.4);
  CHECK(chosen.alpha()[1] == -0.25);
  CHECK(chosen.alpha()[2] == 1.5);
  Mat full(1, 6), mine(1, 4);
  for (int q = 0; q < 2; ++q) {
    lib.Phi(V(1.7), full, Context{.mode = q});
    chosen.Phi(V(1.7), mine, Context{.mode = q});
    CHECK(mine(0, 0) == full(0, 0));
    CHECK(mine(0, 1) == full(0, 2));
    CHECK(mine(0, 2) == full(0, 3));
    CHECK(mine(0, 3) == full(0, 5));
  }
  CHECK_THROWS_WITH(ChosenModelText(text, "tank.toml", {"off_h_3"}, {}), Catch::Contains("'off_h_3' is no candidate"));
}

TEST_CASE("candidates: unknown alpha entries v_1..v_3 with their terms as phi columns in row v", "[model_file][select]") {
  const Model m = ParseModelFile(File(kFlow), "lib.toml").model;
  const ModelSpec& s = m.spec();
  REQUIRE(s.alpha.size() == 5);
  CHECK(s.alpha[2].name == "v_1");
  CHECK(s.alpha[4].name == "v_3");
  CHECK_FALSE(s.alpha[3].known);
  CHECK(s.alpha[3].value == 0.0);
  REQUIRE(s.candidates.size() == 3);
  CHECK(s.candidates[1].alpha == 3);
  CHECK(s.candidates[1].row == 1);
  CHECK(s.candidates[1].term == "abs(v)*v");
  Mat phi(2, 5);
  m.Phi(V(0.5, -3.0), phi);
  CHECK(phi(0, 0) == 3.0 * -1.0);
  CHECK(phi(1, 1) == -0.5);
  CHECK(phi(1, 2) == -3.0);
  CHECK(phi(1, 3) == -9.0);
  CHECK(phi(1, 4) == 1.0);
  CHECK(phi(0, 2) == 0.0);
  CHECK(phi(0, 4) == 0.0);
  // Loaded as the programs load it: no default trajectory is required to reach the guard.
  CHECK_NOTHROW(ParseModelText(File(kFlow), "lib.toml"));
}

TEST_CASE("candidates: a row not identified, a repeated term, a taken name and too many entries are refused",
          "[model_file][select]") {
  auto refused = [](const std::string& flow, const std::string& what) {
    CHECK_THROWS_WITH(ParseModelFile(File(flow), "lib.toml"), Catch::Contains(what));
  };
  refused("[flow]\nphi = [[\"v\", 0], [0, \"-x\"]]\nrows = [\"v\"]\ncandidates = { x = [\"x\"] }\n",
          "flow.candidates.x: 'x' is not one of flow.rows");
  refused("[flow]\nphi = [[\"v\", 0], [0, \"-x\"]]\nrows = [\"v\"]\ncandidates = { v = [\"x\", \"x\"] }\n",
          "flow.candidates.v[1]");
  refused("[flow]\nphi = [[\"v\", 0], [0, \"-x\"]]\nrows = [\"v\"]\ncandidates = { v = [\"y\"] }\n",
          "unknown symbol \"y\"");
  refused("[flow]\nphi = [[\"v\", 0], [0, \"-x\"]]\nrows = [\"v\"]\ncandidates = { w = [\"x\"] }\n", "flow.candidates.w");
  refused("[flow]\nphi = [[\"v\", 0], [0, \"-x\"]]\nrows = [\"v\"]\ncandidates = {}\n",
          "lib.toml:9: flow.candidates: empty: give at least one row of candidate terms");
  std::string many = "[flow]\nphi = [[\"v\", 0], [0, \"-x\"]]\nrows = [\"v\"]\ncandidates = { v = [";
  for (int i = 0; i < 63; ++i) many += "\"x^" + std::to_string(i + 1) + "\", ";
  refused(many + "] }\n", "alpha with the candidates would have more than 64 entries");
  const std::string taken = std::string(kHead).replace(std::string(kHead).find("\"k\""), 3, "\"v_1\"");
  CHECK_THROWS_WITH(ParseModelFile(taken + kFlow + kTail, "lib.toml"), Catch::Contains("'v_1' is already taken"));
}

TEST_CASE("the chosen model: kept candidates as plain entries with the given values, evaluating as the library",
          "[model_file][select]") {
  const Model lib = ParseModelFile(File(kFlow), "lib.toml").model;
  const double kv = -0.123456789012345678, kq = 3.0e-7;
  const std::string text =
      ChosenModelText(File(kFlow), "lib.toml", {"v_2", "v_3"}, {{"k", 4.5}, {"v_2", kv}, {"v_3", kq}, {"e", 0.8}},
                      {"chosen from lib.toml"});
  INFO(text);
  CHECK(text.rfind("# chosen from lib.toml\n", 0) == 0);
  const Model chosen = ParseModelText(text, "chosen.toml");
  const ModelSpec& s = chosen.spec();
  CHECK(s.candidates.empty());
  REQUIRE(s.alpha.size() == 4);
  CHECK(s.alpha[2].name == "v_2");
  CHECK(s.alpha[3].name == "v_3");
  // Values round-trip exactly.
  CHECK(chosen.alpha()[1] == 4.5);
  CHECK(chosen.alpha()[2] == kv);
  CHECK(chosen.alpha()[3] == kq);
  CHECK(chosen.beta()[1] == 0.8);
  Mat full(2, 5), mine(2, 4);
  for (const Vec& x : {V(0.5, -3.0), V(2.0, 0.25)}) {
    lib.Phi(x, full);
    chosen.Phi(x, mine);
    CHECK(mine.col(0) == full.col(0));
    CHECK(mine.col(1) == full.col(1));
    CHECK(mine.col(2) == full.col(3));
    CHECK(mine.col(3) == full.col(4));
  }
  CHECK(s.flow_rows == lib.spec().flow_rows);
  CHECK_THROWS_WITH(ChosenModelText(File(kFlow), "lib.toml", {"v_9"}, {}), Catch::Contains("'v_9' is no candidate"));
}

// A [jump] whose v+ comes from three candidate terms of the pre-jump state besides -e v.
std::string JumpFile(const std::string& candidates) {
  return std::string(kHead) + "[flow]\nphi = [[\"v\", 0], [0, \"-x\"]]\nrows = [\"v\"]\n" +
         "[jump]\npsi = [[\"x\", 0], [0, \"-v\"]]\nrows = [\"v\"]\n" + candidates +
         std::string(kTail).substr(std::string(kTail).find("[[guard]]"));
}

const std::string kJumpCandidates = "candidates = { v = [\"v*abs(v)\", 1, \"x\"] }\n";

TEST_CASE("jump candidates: unknown beta entries jump_v_1..jump_v_3 with their terms as psi columns in row v",
          "[model_file][select]") {
  const Model m = ParseModelFile(JumpFile(kJumpCandidates), "lib.toml").model;
  const ModelSpec& s = m.spec();
  REQUIRE(s.beta.size() == 5);
  CHECK(s.beta[2].name == "jump_v_1");
  CHECK(s.beta[4].name == "jump_v_3");
  CHECK_FALSE(s.beta[3].known);
  CHECK(s.beta[3].value == 0.0);
  CHECK(s.candidates.empty());
  REQUIRE(s.jump_candidates.size() == 3);
  CHECK(s.jump_candidates[0].beta == 2);
  CHECK(s.jump_candidates[0].row == 1);
  CHECK(s.jump_candidates[0].term == "v*abs(v)");
  CHECK(s.jump_candidates[1].term == "1");
  Mat psi(2, 5);
  m.Psi(V(0.25, -3.0), psi);
  CHECK(psi(0, 0) == 0.25);
  CHECK(psi(1, 1) == 3.0);
  CHECK(psi(1, 2) == -9.0);
  CHECK(psi(1, 3) == 1.0);
  CHECK(psi(1, 4) == 0.25);
  for (int c = 2; c < 5; ++c) CHECK(psi(0, c) == 0.0);
  CHECK(s.alpha.size() == 2);  // the flow is as written
  CHECK_NOTHROW(ParseModelText(JumpFile(kJumpCandidates), "lib.toml"));
}

TEST_CASE("jump candidates: a row not identified, a repeated term, a taken name and too many entries are refused "
          "with the key",
          "[model_file][select]") {
  auto refused = [](const std::string& text, const std::string& what) {
    CHECK_THROWS_WITH(ParseModelFile(text, "lib.toml"), Catch::Contains(what));
  };
  refused(JumpFile("candidates = { x = [\"x\"] }\n"), "jump.candidates.x: 'x' is not one of jump.rows");
  refused(JumpFile("candidates = { v = [\"x\", \"x\"] }\n"), "jump.candidates.v[1]");
  refused(JumpFile("candidates = { v = [\"y\"] }\n"), "jump.candidates.v[0]: \"y\": unknown symbol");
  refused(JumpFile("candidates = { v = [] }\n"), "jump.candidates.v");
  refused(JumpFile("candidates = {}\n"), "lib.toml:12: jump.candidates: empty: give at least one row of candidate terms");
  std::string many = "candidates = { v = [";
  for (int i = 0; i < 31; ++i) many += "\"x^" + std::to_string(i + 1) + "\", ";
  refused(JumpFile(many + "] }\n"), "jump.candidates.v[30]: beta with the candidates would have more than 32 entries");
  // A β entry, and a flow candidate, already named jump_v_1.
  const std::string beta_taken = std::string(kHead).replace(std::string(kHead).find("\"e\""), 3, "\"jump_v_1\"");
  refused(beta_taken + JumpFile(kJumpCandidates).substr(std::string(kHead).size()), "'jump_v_1' is already taken");
  const std::string modes = R"toml(
name = "one-mode"
states = ["x", "v"]
modes = ["jump"]
alpha = [ { name = "one", value = 1.0, known = true } ]
beta = [ { name = "one_x", value = 1.0, known = true } ]
[[flow]]
mode = "jump"
phi = [["v"], [0]]
rows = ["v"]
candidates = { v = ["x"] }
[jump]
psi = [["x"], [0]]
rows = ["v"]
candidates = { v = ["v"] }
)toml" + std::string(kTail).substr(std::string(kTail).find("[[guard]]"));
  refused(modes, "jump.candidates.v[0]: the candidate's name 'jump_v_1' is already taken");
}

TEST_CASE("the chosen model with jump candidates: kept ones as plain beta entries, evaluating as the library",
          "[model_file][select]") {
  const std::string file = JumpFile(kJumpCandidates);
  const Model lib = ParseModelFile(file, "lib.toml").model;
  const double c = -0.0123456789012345678;
  const std::string text = ChosenModelText(file, "lib.toml", {"jump_v_1", "jump_v_3"},
                                           {{"e", 0.8}, {"jump_v_1", c}, {"jump_v_3", 2.5}});
  INFO(text);
  const Model chosen = ParseModelText(text, "chosen.toml");
  const ModelSpec& s = chosen.spec();
  CHECK(s.jump_candidates.empty());
  REQUIRE(s.beta.size() == 4);
  CHECK(s.beta[2].name == "jump_v_1");
  CHECK(s.beta[3].name == "jump_v_3");
  CHECK(chosen.beta()[1] == 0.8);
  CHECK(chosen.beta()[2] == c);
  CHECK(chosen.beta()[3] == 2.5);
  Mat full(2, 5), mine(2, 4);
  for (const Vec& x : {V(0.25, -3.0), V(0.0, -0.5)}) {
    lib.Psi(x, full);
    chosen.Psi(x, mine);
    CHECK(mine.col(1) == full.col(1));
    CHECK(mine.col(2) == full.col(2));
    CHECK(mine.col(3) == full.col(4));
  }
  CHECK(s.jump_rows == lib.spec().jump_rows);
  CHECK_THROWS_WITH(ChosenModelText(file, "lib.toml", {"jump_v_4"}, {}), Catch::Contains("'jump_v_4' is no candidate"));
}

// A ball between a floor and a ceiling, one [[jump]] map each, with candidate terms of v+ in both maps
// (`floor` and `ceiling`: extra keys of each map's table).
std::string TwoMaps(const std::string& floor, const std::string& ceiling) {
  return R"toml(
name = "two-maps-lib"
states = ["h", "v"]
alpha = [ { name = "one", value = 1.0, known = true }, { name = "g", value = 9.81 } ]
[flow]
phi = [["v", 0], [0, -1]]
rows = ["v"]
[[jump]]
name = "floor"
guard = "floor"
beta = [ { name = "one_f", value = 1.0, known = true }, { name = "e_floor", value = 0.9 } ]
psi = [["h", 0], [0, "-v"]]
rows = ["v"]
)toml" + floor + R"toml(
[[jump]]
name = "ceiling"
guard = "ceiling"
beta = [ { name = "one_c", value = 1.0, known = true }, { name = "e_ceiling", value = 0.7 } ]
psi = [["h", 0], [0, "-v"]]
rows = ["v"]
)toml" + ceiling + R"toml(
[[guard]]
name = "floor"
h = "h"
direction = "falling"
project = { h = "0" }
[[guard]]
name = "ceiling"
h = "h - 2"
direction = "rising"
project = { h = "2" }
[defaults]
x0 = [1.0, 15.0]
t_end = 5.0
)toml";
}

const std::string kFloorTerms = "candidates = { v = [\"v*abs(v)\", \"1\"] }\n";
const std::string kCeilingTerms = "candidates = { v = [\"v^3\"] }\n";

TEST_CASE("[[jump]] candidates: MAP_ROW_K entries in the map's beta slice, their psi columns in that map only",
          "[model_file][select]") {
  const Model m = ParseModelText(TwoMaps(kFloorTerms, kCeilingTerms), "lib.toml");
  const ModelSpec& s = m.spec();
  REQUIRE(s.beta.size() == 7);
  const std::vector<std::string> names = {"one_f", "e_floor", "floor_v_1", "floor_v_2", "one_c", "e_ceiling",
                                          "ceiling_v_1"};
  for (std::size_t i = 0; i < names.size(); ++i) CHECK(s.beta[i].name == names[i]);
  CHECK(!s.beta[2].known);
  CHECK(s.beta[2].value == 0.0);
  REQUIRE(s.jumps.size() == 2);
  CHECK(s.jumps[0].beta_first == 0);
  CHECK(s.jumps[0].beta_count == 4);
  CHECK(s.jumps[1].beta_first == 4);
  CHECK(s.jumps[1].beta_count == 3);
  REQUIRE(s.jump_candidates.size() == 3);
  CHECK(s.jump_candidates[0].beta == 2);
  CHECK(s.jump_candidates[0].map == 0);
  CHECK(s.jump_candidates[1].term == "1");
  CHECK(s.jump_candidates[2].beta == 6);
  CHECK(s.jump_candidates[2].map == 1);
  CHECK(s.jump_candidates[2].row == 1);
  Mat psi(2, 7);
  m.Psi(V(0.1, -3.0), psi, Context{.map = 0});
  CHECK(psi(0, 0) == 0.1);
  CHECK(psi(1, 1) == 3.0);
  CHECK(psi(1, 2) == -9.0);
  CHECK(psi(1, 3) == 1.0);
  CHECK(psi(0, 2) == 0.0);
  for (int c = 4; c < 7; ++c) CHECK(psi.col(c).isZero());
  m.Psi(V(1.9, 2.0), psi, Context{.map = 1});
  for (int c = 0; c < 4; ++c) CHECK(psi.col(c).isZero());
  CHECK(psi(0, 4) == 1.9);
  CHECK(psi(1, 5) == -2.0);
  CHECK(psi(1, 6) == 8.0);
  CHECK(psi(0, 6) == 0.0);
  CHECK(s.jump_rows == std::vector<int>{1});
}

TEST_CASE("[[jump]] candidates: an identity map, a map name that makes no name, a taken name and a row not the "
          "map's are refused with the key",
          "[model_file][select]") {
  auto refused = [](const std::string& text, const std::string& what) {
    CHECK_THROWS_WITH(ParseModelFile(text, "lib.toml"), Catch::Contains(what));
  };
  std::string dashed = TwoMaps(kFloorTerms, "");
  dashed.replace(dashed.find("name = \"floor\"\nguard"), 14, "name = \"floor-1\"");
  refused(dashed, "jump[0].candidates: map 'floor-1' does not make candidate names MAP_ROW_K");
  refused(TwoMaps(kFloorTerms, "").replace(TwoMaps(kFloorTerms, "").find("\"one_c\""), 7, "\"floor_v_2\""),
          "'floor_v_2' is already the name of a parameter");
  refused(TwoMaps("candidates = { h = [\"h\"] }\n", ""), "jump[0].candidates.h: 'h' is not one of jump[0].rows");
  refused(Automaton(kOff, kOn).replace(Automaton(kOff, kOn).find("to = \"on\"\n") + 10, 0,
                                       "candidates = { h = [\"h\"] }\n"),
          "jump[0].candidates: an identity map (no psi: a mode switch, ξ+ = ξ) has no candidate terms");
}

TEST_CASE("the chosen model with [[jump]] candidates: kept ones in their map's beta and psi, evaluating as the library",
          "[model_file][select]") {
  const std::string file = TwoMaps(kFloorTerms, kCeilingTerms);
  const Model lib = ParseModelFile(file, "lib.toml").model;
  const std::string text = ChosenModelText(file, "lib.toml", {"floor_v_2", "ceiling_v_1"},
                                           {{"e_floor", 0.85}, {"floor_v_2", 0.125}, {"ceiling_v_1", -0.01}});
  INFO(text);
  const Model chosen = ParseModelText(text, "chosen.toml");
  const ModelSpec& s = chosen.spec();
  CHECK(s.jump_candidates.empty());
  REQUIRE(s.beta.size() == 6);
  const std::vector<std::string> names = {"one_f", "e_floor", "floor_v_2", "one_c", "e_ceiling", "ceiling_v_1"};
  for (std::size_t i = 0; i < names.size(); ++i) CHECK(s.beta[i].name == names[i]);
  CHECK(chosen.beta()[1] == 0.85);
  CHECK(chosen.beta()[2] == 0.125);
  CHECK(chosen.beta()[5] == -0.01);
  CHECK(s.jumps[0].beta_count == 3);
  CHECK(s.jumps[1].beta_first == 3);
  Mat full(2, 7), mine(2, 6);
  for (const Vec& x : {V(0.1, -3.0), V(1.9, 2.5)}) {
    for (int map : {0, 1}) {
      lib.Psi(x, full, Context{.map = map});
      chosen.Psi(x, mine, Context{.map = map});
      CHECK(mine.col(1) == full.col(1));
      CHECK(mine.col(2) == full.col(3));
      CHECK(mine.col(4) == full.col(5));
      CHECK(mine.col(5) == full.col(6));
    }
  }
  CHECK_THROWS_WITH(ChosenModelText(file, "lib.toml", {"ceiling_v_2"}, {}), Catch::Contains("'ceiling_v_2' is no candidate"));
}

TEST_CASE("the chosen model: a flow table with a kept term is not declared jacobian_constant, one without keeps it",
          "[model_file][select]") {
  const std::string flow = "[flow]\nphi = [[\"v\", 0], [0, \"-x\"]]\nrows = [\"v\"]\njacobian_constant = true\n"
                           "candidates = { v = [\"v^2\", \"x\"] }\n";
  const Model lib = ParseModelFile(File(flow), "lib.toml").model;
  CHECK_FALSE(lib.spec().flow_jacobian_constant);
  // v^2 kept: d(phi alpha)/dv depends on v, so the chosen model may not declare it constant.
  const std::string kept = ChosenModelText(File(flow), "lib.toml", {"v_1"}, {{"v_1", -0.5}});
  INFO(kept);
  const Model chosen = ParseModelText(kept, "chosen.toml");
  CHECK_FALSE(chosen.spec().flow_jacobian_constant);
  Mat jac(2, 2);
  chosen.FlowJacobian(V(0.0, 2.0), chosen.alpha(), jac);
  CHECK(jac(1, 1) == Approx(-2.0).margin(1e-6));  // d(-0.5 v^2)/dv at v = 2 (central differences)
  // Only jump candidates: the flow is as written, and so is its declaration.
  std::string jump_only = JumpFile(kJumpCandidates);
  jump_only.insert(jump_only.find("[jump]"), "jacobian_constant = true\n");
  REQUIRE(ParseModelFile(jump_only, "lib.toml").model.spec().flow_jacobian_constant);
  CHECK(ParseModelText(ChosenModelText(jump_only, "lib.toml", {"jump_v_1"}, {}), "chosen.toml")
            .spec()
            .flow_jacobian_constant);
}

TEST_CASE("the chosen model: a number term beyond 2^53 keeps its value (the library's column)", "[model_file][select]") {
  const std::string file = JumpFile("candidates = { v = [123456789012345678, 0.1, \"v\"] }\n");
  const Model lib = ParseModelFile(file, "lib.toml").model;
  const std::string text = ChosenModelText(file, "lib.toml", {"jump_v_1", "jump_v_2"}, {});
  INFO(text);
  CHECK(text.find("chosen candidate jump term 123456789012345678") != std::string::npos);
  const Model chosen = ParseModelText(text, "chosen.toml");
  Mat full(2, 5), mine(2, 4);
  lib.Psi(V(0.25, -3.0), full);
  chosen.Psi(V(0.25, -3.0), mine);
  CHECK(full(1, 2) == 123456789012345680.0);  // the integer's nearest double
  CHECK(mine(1, 2) == full(1, 2));
  CHECK(mine(1, 3) == 0.1);
}

}  // namespace hysid
