// Modes and jump maps in a ModelSpec: which map a guard applies in a mode, the mode after it, the
// identity map, and the refusals of an inconsistent automaton.
#include <stdexcept>

#include <catch2/catch.hpp>

#include "core/model/automaton.hpp"

namespace hysid {
namespace {

Parameter Param(const char* name, double value, bool known = false) {
  Parameter p;
  p.name = name;
  p.value = value;
  p.known = known;
  return p;
}

JumpMap Map(const char* name, int guard, int from, int to, int beta_first, int beta_count, bool identity = false) {
  JumpMap m;
  m.name = name;
  m.guard = guard;
  m.from = from;
  m.to = to;
  m.beta_first = beta_first;
  m.beta_count = beta_count;
  if (!identity) m.rows = {1};
  m.identity = identity;
  return m;
}

Vec Two(double a, double b) {
  Vec x(2);
  x(0) = a;
  x(1) = b;
  return x;
}

// A ball between a floor (h = 0) and a ceiling (h = 1) with one restitution each, and a "switch" map
// that is an identity: ψ_m(ξ) has its map's β slice only (Context::map).
struct TwoWalls {
  std::vector<JumpMap> jumps = {
      Map("floor", 0, -1, -1, 0, 1),
      Map("ceiling", 1, -1, -1, 1, 1),
  };
  std::vector<std::string> modes = {};
  ModelSpec Spec() const {
    ModelSpec s;
    s.name = "two-walls";
    s.state_names = {"h", "v"};
    s.alpha = {Param("one", 1.0, true), Param("g", 9.81)};
    s.beta = {Param("e_floor", 0.8), Param("e_ceiling", 0.5)};
    s.flow_rows = {1};
    s.jump_rows = {1};
    s.guards = {Guard{"floor", Crossing::kFalling}, Guard{"ceiling", Crossing::kRising}};
    s.default_x0 = {0.5, 1.0};
    s.modes = modes;
    s.jumps = jumps;
    return s;
  }
  void Phi(ConstVecRef x, const Context&, MatRef phi) const {
    phi.setZero();
    phi(0, 0) = x(1);
    phi(1, 1) = -1.0;
  }
  void Psi(ConstVecRef x, const Context& ctx, MatRef psi) const {
    psi.setZero();
    psi(0, ctx.map) = x(0) / 0.8;  // so that ψβ keeps h only with the map's own β (any value works)
    psi(1, ctx.map) = -x(1);
  }
  void Guards(ConstVecRef x, const Context&, VecRef h) const {
    h(0) = x(0);
    h(1) = x(0) - 1.0;
  }
  bool InFlowSet(ConstVecRef, const Context&) const { return true; }
  bool InJumpSet(ConstVecRef, const Context&) const { return false; }
};

TEST_CASE("each guard applies its own map and its own slice of beta") {
  const Model model{TwoWalls{}};
  const ModelSpec& spec = model.spec();
  REQUIRE(IsAutomaton(spec));
  CHECK(ModeCount(spec) == 1);
  CHECK(ArmedMap(spec, 0, 0) == 0);
  CHECK(ArmedMap(spec, 0, 1) == 1);
  CHECK(ModeAfter(spec, 0, 1) == 0);
  const Vec x = Two(1.0, 2.0);
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
  TwoWalls plain;
  plain.jumps.clear();
  const ModelSpec spec = plain.Spec();
  CHECK_FALSE(IsAutomaton(spec));
  const std::vector<JumpMap> maps = JumpMaps(spec);
  REQUIRE(maps.size() == 1);
  CHECK(maps[0].beta_count == 2);
  CHECK(ArmedMap(spec, 0, 1) == 0);
}

TEST_CASE("modes: a map is armed only in its from-mode, an identity map keeps the state") {
  TwoWalls m;
  m.modes = {"down", "up"};
  m.jumps = {
      Map("floor", 0, 0, 1, 0, 2),
      Map("switch", 1, 1, 0, 0, 0, true),
  };
  const Model model{m};
  const ModelSpec& spec = model.spec();
  CHECK(ModeCount(spec) == 2);
  CHECK(ArmedMap(spec, 0, 0) == 0);
  CHECK(ArmedMap(spec, 1, 0) == -1);
  CHECK(ArmedMap(spec, 0, 1) == -1);
  CHECK(ArmedMap(spec, 1, 1) == 1);
  CHECK(ModeAfter(spec, 0, 0) == 1);
  CHECK(ModeAfter(spec, 1, 1) == 0);
  const Vec x = Two(0.3, -4.0);
  Vec post(2);
  Context ctx;
  ctx.map = 1;
  model.Jump(x, model.beta(), post, ctx);
  CHECK(post == x);
}

TEST_CASE("an inconsistent automaton is refused naming the map or guard") {
  TwoWalls m;
  m.jumps[1].guard = 0;  // two maps on the floor, none on the ceiling
  CHECK_THROWS_AS(Model{m}, std::invalid_argument);
  m = TwoWalls{};
  m.jumps[1].beta_first = 0;  // both maps claim e_floor
  CHECK_THROWS_AS(Model{m}, std::invalid_argument);
  m = TwoWalls{};
  m.jumps[1].from = 3;  // no mode 3
  CHECK_THROWS_AS(Model{m}, std::invalid_argument);
  m = TwoWalls{};
  m.modes = {"a", "b"};
  m.jumps.clear();  // modes without maps
  CHECK_THROWS_AS(Model{m}, std::invalid_argument);
}

}  // namespace
}  // namespace hysid
