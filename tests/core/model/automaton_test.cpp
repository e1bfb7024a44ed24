// Modes and jump maps in a ModelSpec: which map a guard applies in a mode, the mode after it, the
// identity map, and the refusals of an inconsistent automaton.
#include <stdexcept>

#include <catch2/catch.hpp>

#include "core/model/automaton.hpp"
#include "tests/sim/automaton_models.hpp"

namespace hysid {
namespace {

using testing::FloorCeiling;
using testing::Map;
using testing::Of;

TEST_CASE("each guard applies its own map and its own slice of beta") {
  const Model model{FloorCeiling{}};
  const ModelSpec& spec = model.spec();
  REQUIRE(IsAutomaton(spec));
  CHECK(ModeCount(spec) == 1);
  CHECK(ArmedMap(spec, 0, 0) == 0);
  CHECK(ArmedMap(spec, 0, 1) == 1);
  CHECK(ModeAfter(spec, 0, 1) == 0);
  const Vec x = Of({1.0, 2.0});
  Vec post(2);
  Context ctx;
  ctx.map = 1;
  model.Jump(x, model.beta(), post, ctx);
  CHECK(post(1) == -2.0 * 0.5);  // the ceiling's restitution, not the floor's
  ctx.map = 0;
  model.Jump(x, model.beta(), post, ctx);
  CHECK(post(1) == -2.0 * 0.8);
}

TEST_CASE("the paper's class has one implicit map that every guard triggers") {
  FloorCeiling plain;
  plain.jumps.clear();
  const ModelSpec spec = plain.Spec();
  CHECK_FALSE(IsAutomaton(spec));
  const std::vector<JumpMap> maps = JumpMaps(spec);
  REQUIRE(maps.size() == 1);
  CHECK(maps[0].beta_count == 4);
  CHECK(ArmedMap(spec, 0, 1) == 0);
}

TEST_CASE("modes: a map is armed only in its from-mode, an identity map keeps the state") {
  FloorCeiling m;
  m.modes = {"down", "up"};
  m.jumps = {
      Map("floor", 0, 0, 1, 0, 2),
      Map("ceiling", 1, 0, 0, 2, 2),
      Map("switch", 1, 1, 0, 0, 0),
  };
  const Model model{m};
  const ModelSpec& spec = model.spec();
  CHECK(ModeCount(spec) == 2);
  CHECK(ArmedMap(spec, 0, 0) == 0);
  CHECK(ArmedMap(spec, 1, 0) == -1);
  CHECK(ArmedMap(spec, 0, 1) == 1);
  CHECK(ArmedMap(spec, 1, 1) == 2);
  CHECK(ModeAfter(spec, 0, 0) == 1);
  CHECK(ModeAfter(spec, 0, 1) == 0);
  CHECK(ModeAfter(spec, 1, 2) == 0);
  const Vec x = Of({0.3, -4.0});
  Vec post(2);
  Context ctx;
  ctx.map = 2;
  model.Jump(x, model.beta(), post, ctx);
  CHECK(post == x);
}

TEST_CASE("an inconsistent automaton is refused naming the map or guard") {
  FloorCeiling m;
  m.jumps[1].guard = 0;  // two maps on the floor, none on the ceiling
  CHECK_THROWS_AS(Model{m}, std::invalid_argument);
  m = FloorCeiling{};
  m.jumps[1].beta_first = 0;  // both maps claim one_f and e_floor
  CHECK_THROWS_AS(Model{m}, std::invalid_argument);
  m = FloorCeiling{};
  m.jumps[1].from = 3;  // no mode 3
  CHECK_THROWS_AS(Model{m}, std::invalid_argument);
  m = FloorCeiling{};
  m.modes = {"a", "b"};
  m.jumps.clear();  // modes without maps
  CHECK_THROWS_AS(Model{m}, std::invalid_argument);
}

}  // namespace
}  // namespace hysid
