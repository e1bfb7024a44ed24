// Hybrid automata as C++ structs for the model, identification, run-loop, sensitivity and refinement
// tests: a ball between a floor and a ceiling with one restitution each (two jump maps), and a pump
// tank with two flow modes that switch at thresholds h_lo, h_hi (identity maps, β empty).
#pragma once

#include <cmath>
#include <initializer_list>
#include <string>
#include <vector>

#include "core/model/model.hpp"

namespace hysid::testing {

inline Parameter Param(const char* name, double value, bool known = false) {
  Parameter p;
  p.name = name;
  p.value = value;
  p.known = known;
  return p;
}

// A vector from a list: Of({0.5, 4.0}).
inline Vec Of(std::initializer_list<double> v) {
  Vec x(static_cast<Eigen::Index>(v.size()));
  Eigen::Index i = 0;
  for (double d : v) x[i++] = d;
  return x;
}

inline JumpMap Map(const char* name, int guard, int from, int to, int beta_first, int beta_count) {
  JumpMap m;
  m.name = name;
  m.guard = guard;
  m.from = from;
  m.to = to;
  m.beta_first = beta_first;
  m.beta_count = beta_count;
  m.identity = beta_count == 0;
  if (!m.identity) m.rows = {1};
  return m;
}

// h' = v, v' = −g; floor h = 0 (falling): v⁺ = −e_floor·v; ceiling h = H (rising): v⁺ = −e_ceiling·v.
// β = (one_f, e_floor, one_c, e_ceiling), ψ_m = [[h, 0], [0, −v]] on map m's slice. The one struct of
// the two walls for every test (the model's and the identification's too): `jumps` and `modes` may
// be changed before Spec() (an inconsistent automaton to refuse, modes with an identity map), and
// `one_map` makes the paper's class, one restitution e = β1 for both walls (β = (one_b, e)).
struct FloorCeiling {
  double ceiling = 1.0;
  double g = 9.81;
  double e_floor = 0.8, e_ceiling = 0.5;
  std::vector<double> x0 = {0.5, 4.0};
  bool one_map = false;
  std::vector<std::string> modes = {};
  std::vector<JumpMap> jumps = {Map("floor", 0, -1, -1, 0, 2), Map("ceiling", 1, -1, -1, 2, 2)};
  ModelSpec Spec() const {
    ModelSpec s;
    s.name = "floor-ceiling";
    s.state_names = {"h", "v"};
    s.alpha = {Param("one", 1.0, true), Param("g", g)};
    if (one_map) {
      s.beta = {Param("one_b", 1.0, true), Param("e", e_floor)};
    } else {
      s.beta = {Param("one_f", 1.0, true), Param("e_floor", e_floor), Param("one_c", 1.0, true),
                Param("e_ceiling", e_ceiling)};
      s.jumps = jumps;
    }
    s.flow_rows = {1};
    s.jump_rows = {1};
    s.guards = {Guard{"floor", Crossing::kFalling}, Guard{"ceiling", Crossing::kRising}};
    s.default_x0 = x0;
    s.modes = modes;
    return s;
  }
  void Phi(ConstVecRef x, const Context&, MatRef phi) const {
    phi.setZero();
    phi(0, 0) = x(1);
    phi(1, 1) = -1.0;
  }
  void Psi(ConstVecRef x, const Context& ctx, MatRef psi) const {
    psi.setZero();
    const int m = one_map || ctx.map < 0 ? 0 : ctx.map;
    if (2 * m + 1 >= psi.cols()) return;  // an identity map (Model::Jump does not read ψ)
    psi(0, 2 * m) = x(0);
    psi(1, 2 * m + 1) = -x(1);
  }
  void Guards(ConstVecRef x, const Context&, VecRef h) const {
    h(0) = x(0);
    h(1) = x(0) - ceiling;
  }
  void ProjectOntoGuard(int i, const Context&, VecRef x) const { x(0) = i == 0 ? 0.0 : ceiling; }
  bool InFlowSet(ConstVecRef, const Context&) const { return true; }
  bool InJumpSet(ConstVecRef, const Context&) const { return false; }
};

// h' = −a√h + P·[q = on]; modes (off, on); pump-on: off → on at h = h_lo falling; pump-off: on → off
// at h = h_hi rising; both identity maps; γ = (h_lo, h_hi).
struct PumpTank {
  ModelSpec Spec() const {
    ModelSpec s;
    s.name = "pump-tank";
    s.state_names = {"h"};
    s.alpha = {Param("a", 0.5), Param("P", 1.0)};
    s.guard_params = {Param("h_lo", 1.0), Param("h_hi", 2.0)};
    s.flow_rows = {0};
    s.guards = {Guard{"low", Crossing::kFalling}, Guard{"high", Crossing::kRising}};
    s.default_x0 = {1.5};
    s.modes = {"off", "on"};
    s.default_mode = 1;
    s.jumps = {Map("pump-on", 0, 0, 1, 0, 0), Map("pump-off", 1, 1, 0, 0, 0)};
    return s;
  }
  void Phi(ConstVecRef x, const Context& ctx, MatRef phi) const {
    phi(0, 0) = -std::sqrt(x(0));
    phi(0, 1) = ctx.mode == 1 ? 1.0 : 0.0;
  }
  void Psi(ConstVecRef, const Context&, MatRef psi) const { psi.setZero(); }
  void Guards(ConstVecRef x, const Context& ctx, VecRef h) const {
    h(0) = x(0) - ctx.gamma[0];
    h(1) = x(0) - ctx.gamma[1];
  }
  void ProjectOntoGuard(int i, const Context& ctx, VecRef x) const { x(0) = ctx.gamma[i]; }
  bool InFlowSet(ConstVecRef x, const Context&) const { return x(0) > 0.0; }
  bool InJumpSet(ConstVecRef, const Context&) const { return false; }
};

// Both flow modes and a state jump, the jump in mode 1: x' = −a·x + P·[q = fill]; fill → drain at
// x = 3 rising (an identity map, "drain"); in drain, at x = 1 falling, the map "refill" jumps
// x⁺ = c·x and goes back to fill. α = (a, P) = (0.5, 2), β = (c) = (2): from x0 = 2 in fill a cycle
// of 1.39 s filling and 2.20 s draining. In drain, mode fill's flow is off by P per unit time.
struct RefillTank {
  ModelSpec Spec() const {
    ModelSpec s;
    s.name = "refill-tank";
    s.state_names = {"x"};
    s.alpha = {Param("a", 0.5), Param("P", 2.0)};
    s.beta = {Param("c", 2.0)};
    s.flow_rows = {0};
    s.jump_rows = {0};
    s.guards = {Guard{"low", Crossing::kFalling}, Guard{"high", Crossing::kRising}};
    s.default_x0 = {2.0};
    s.modes = {"fill", "drain"};
    JumpMap refill = Map("refill", 0, 1, 0, 0, 1);
    refill.rows = {0};
    s.jumps = {refill, Map("drain", 1, 0, 1, 0, 0)};
    return s;
  }
  void Phi(ConstVecRef x, const Context& ctx, MatRef phi) const {
    phi(0, 0) = -x(0);
    phi(0, 1) = ctx.mode == 0 ? 1.0 : 0.0;
  }
  void Psi(ConstVecRef x, const Context& ctx, MatRef psi) const {
    psi.setZero();
    if (ctx.map == 0) psi(0, 0) = x(0);
  }
  void Guards(ConstVecRef x, const Context&, VecRef h) const {
    h(0) = x(0) - 1.0;
    h(1) = x(0) - 3.0;
  }
  void ProjectOntoGuard(int i, const Context&, VecRef x) const { x(0) = i == 0 ? 1.0 : 3.0; }
  bool InFlowSet(ConstVecRef, const Context&) const { return true; }
  bool InJumpSet(ConstVecRef, const Context&) const { return false; }
};

}  // namespace hysid::testing
