// Candidate terms in a model file ([flow] candidates) and the chosen model written from them
// (core/model_file/chosen.hpp): each candidate is an unknown α entry ROW_K whose φ column is its term
// in its row; the chosen model keeps the kept candidates as plain entries, with the values given, and
// evaluates as the library's columns do.
#include <catch2/catch.hpp>

#include <string>

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

}  // namespace

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
  std::string many = "[flow]\nphi = [[\"v\", 0], [0, \"-x\"]]\nrows = [\"v\"]\ncandidates = { v = [";
  for (int i = 0; i < 31; ++i) many += "\"x^" + std::to_string(i + 1) + "\", ";
  refused(many + "] }\n", "more than 32 entries");
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

}  // namespace hysid
