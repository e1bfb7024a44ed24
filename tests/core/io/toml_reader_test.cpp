// The TOML reader of sweep and model files: each violation has one wording, prefixed by
// "FILE:LINE: KEY", and a missing top-level key carries no line (the top level has none of its own).
#include <catch2/catch.hpp>

#include <stdexcept>
#include <string>
#include <vector>

#include "core/io/toml_reader.hpp"

namespace hysid {
namespace {

const char* kText = R"(top = 1
[t]
s = "word"
n = 2.5
i = 7
big = 4294967296
b = true
list = [1, 2, "x"]
inline = { a = 1 }
nan = nan
)";

// The message of what `read` throws.
template <class F>
std::string ErrorOf(F read) {
  try {
    read();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST_CASE("typed values read back, and each wrong type names what it got", "[toml]") {
  const toml::table root = ParseToml(kText, "f.toml");
  const TomlReader rd("f.toml");
  const toml::table& t = rd.Table(rd.Require(root, "", "t"), "t");
  REQUIRE(rd.String(*t.get("s"), "t.s") == "word");
  REQUIRE(rd.Number(*t.get("n"), "t.n") == 2.5);
  REQUIRE(rd.Number(*t.get("i"), "t.i") == 7.0);
  REQUIRE(rd.Integer(*t.get("i"), "t.i", 7, 7) == 7);
  REQUIRE(rd.Boolean(*t.get("b"), "t.b"));
  REQUIRE(rd.Table(*t.get("inline"), "t.inline").contains("a"));
  REQUIRE(rd.Array(*t.get("list"), "t.list").size() == 3);
  REQUIRE(ErrorOf([&] { rd.Number(*t.get("s"), "t.s"); }) ==
          "f.toml:3: t.s: expected a number, got a string");
  REQUIRE(ErrorOf([&] { rd.String(*t.get("n"), "t.n"); }) ==
          "f.toml:4: t.n: expected a string, got a number");
  REQUIRE(ErrorOf([&] { rd.Integer(*t.get("n"), "t.n"); }) ==
          "f.toml:4: t.n: expected an integer, got a number");
  REQUIRE(ErrorOf([&] { rd.Boolean(*t.get("i"), "t.i"); }) ==
          "f.toml:5: t.i: expected true or false, got an integer");
  REQUIRE(ErrorOf([&] { rd.Table(*t.get("list"), "t.list"); }) ==
          "f.toml:8: t.list: expected a table, got a list");
  REQUIRE(ErrorOf([&] { rd.Array(*t.get("inline"), "t.inline"); }) ==
          "f.toml:9: t.inline: expected a list, got a table");
  REQUIRE(ErrorOf([&] { rd.Numbers(*t.get("list"), "t.list"); }) ==
          "f.toml:8: t.list[2]: expected a number, got a string");
}

TEST_CASE("an integer as a number: its nearest double, beyond 2^53 too", "[toml]") {
  const toml::table root = ParseToml("a = 9007199254740993\nb = 123456789012345678\nc = -9223372036854775808\n", "f.toml");
  const TomlReader rd("f.toml");
  CHECK(rd.Number(*root.get("a"), "a") == 9007199254740992.0);  // 2^53 + 1: a tie, to the even 2^53
  CHECK(rd.Number(*root.get("b"), "b") == 123456789012345680.0);
  CHECK(rd.Number(*root.get("c"), "c") == -9223372036854775808.0);  // -2^63
  const toml::table list = ParseToml("l = [9007199254740995]", "g.toml");
  CHECK(rd.Numbers(*list.get("l"), "l") == std::vector<double>{9007199254740996.0});  // 2^53 + 3: a tie, to even
}

TEST_CASE("keys: unknown, missing (with and without a line), exclusive", "[toml]") {
  const toml::table root = ParseToml(kText, "f.toml");
  const TomlReader rd("f.toml");
  const toml::table& t = *root.get("t")->as_table();
  REQUIRE(ErrorOf([&] {
            rd.OnlyKeys(t, "t", {"s", "n", "i", "big", "b", "list", "inline"});
          }) == "f.toml:10: t.nan: unknown key (known here: s, n, i, big, b, list, inline)");
  REQUIRE(ErrorOf([&] { rd.Require(t, "t", "x"); }) == "f.toml:2: t.x: missing");
  REQUIRE(ErrorOf([&] { rd.Require(root, "", "grid", "a [grid] table"); }) ==
          "f.toml: grid: missing: a [grid] table");
  REQUIRE(ErrorOf([&] { rd.NotBoth(t, "t", "s", "n"); }) == "f.toml:4: t.n: give s or n, not both");
  rd.NotBoth(t, "t", "s", "absent");  // one of them: accepted
}

TEST_CASE("ranges, sizes and names: one wording each", "[toml]") {
  const toml::table root = ParseToml(kText, "f.toml");
  const TomlReader rd("f.toml");
  const toml::table& t = *root.get("t")->as_table();
  REQUIRE(ErrorOf([&] { rd.Number(*t.get("nan"), "t.nan"); }) == "f.toml:10: t.nan: nan must be finite");
  REQUIRE(ErrorOf([&] { rd.Integer(*t.get("i"), "t.i", 8); }) == "f.toml:5: t.i: 7 must be ≥ 8");
  REQUIRE(ErrorOf([&] { rd.Integer(*t.get("big"), "t.big", 1, 2147483647); }) ==
          "f.toml:6: t.big: 4294967296 must be ≤ 2147483647");
  REQUIRE(ErrorOf([&] { rd.Above(t.get("n"), "t.n", 2.5, 2.5); }) == "f.toml:4: t.n: 2.5 must be > 2.5");
  REQUIRE(ErrorOf([&] { rd.AtLeast(t.get("n"), "t.n", -0.5, 0.0); }) == "f.toml:4: t.n: -0.5 must be ≥ 0");
  rd.AtLeast(t.get("n"), "t.n", 0.0, 0.0);
  REQUIRE(ErrorOf([&] { rd.Size(t.get("list"), "t.list", 3, 2, "one per state"); }) ==
          "f.toml:8: t.list: has 3 entries, expected 2 (one per state)");
  REQUIRE(ErrorOf([&] { rd.NotEmpty(t.get("list"), "t.list", 0, "value"); }) ==
          "f.toml:8: t.list: empty: give at least one value");
  REQUIRE(rd.Choice(t.get("s"), "t.s", "state", "v", {"x", "v"}) == 1);
  REQUIRE(ErrorOf([&] {
            rd.Choice(t.get("s"), "t.s", "state", "w", {"x", "v"});
          }) == "f.toml:3: t.s: unknown state 'w' (known: x, v)");
  REQUIRE(ErrorOf([&] { rd.Twice(t.get("s"), "t.s", "'word'"); }) == "f.toml:3: t.s: 'word' appears twice");
}

}  // namespace
}  // namespace hysid
