// A ball under gravity g bouncing on the floor h = 0 with restitution λ and impact term μ.
// The flow is affine: f(0) = (0, −g) ≠ 0, so Assumption 2.3 of the paper does not hold.
//   ξ = (h, v),  ξ' = [ξ2; −g] = φ(ξ)α,  φ = [[ξ2, 0], [0, −1]],  α = (1, g)
//   ξ+ = [ξ1; −λξ2 + μ] = ψ(ξ)β,          ψ = [[ξ1, 0, 0], [0, −ξ2, 1]],  β = (1, λ, μ)
//   C = {ξ1 ≥ 0} \ {ξ1 = 0, ξ2 < 0},  D = {ξ1 = 0, ξ2 ≤ 0}
// With μ = 0 and λ < 1 the impacts accumulate (Zeno) at
//   t_Z = √(2h0/g) + 2λ√(2gh0) / (g(1 − λ))   for ξ(0) = (h0, 0).
#pragma once

#include <algorithm>
#include <cmath>

#include "core/model/model.hpp"

namespace hysid {

struct BouncingBall {
  ModelSpec Spec() const {
    return ModelSpec{
        .name = "bouncing-ball",
        .description = "ball under gravity with restitution (affine flow, Zeno)",
        .state_names = {"h", "v"},
        .alpha = {{"alpha_h", 1.0, true, "coefficient of v in h' (known)"},
                  {"g", 9.81, false, "gravitational acceleration"}},
        .beta = {{"beta_h", 1.0, true, "coefficient of h in h+ (known)"},
                 {"lambda", 0.8, false, "restitution coefficient"},
                 {"mu", 0.0, false, "additive impact term"}},
        .flow_rows = {1},
        .jump_rows = {1},
        .guards = {{"floor", Crossing::kFalling}},
        .flow_jacobian_constant = true,
        .default_x0 = {1.0, 0.0},
        .default_t_end = 10.0,
        .default_dt = 1e-3,
        .equations =
            "flow: h' = alpha_h*v, v' = -g\n"
            "jump: h+ = beta_h*h, v+ = -lambda*v + mu\n"
            "guard floor: h(xi) = h (falling)\n"
            "C: h > 0 || (h == 0 && v >= 0)\n"
            "D: h == 0 && v <= 0\n",
    };
  }
  void Phi(ConstVecRef x, MatRef phi) const {
    phi << x[1], 0.0,  //
        0.0, -1.0;
  }
  void Psi(ConstVecRef x, MatRef psi) const {
    psi << x[0], 0.0, 0.0,  //
        0.0, -x[1], 1.0;
  }
  void Guards(ConstVecRef x, VecRef h) const { h[0] = x[0]; }
  bool InFlowSet(ConstVecRef x) const { return x[0] > 0.0 || (x[0] == 0.0 && x[1] >= 0.0); }
  bool InJumpSet(ConstVecRef x) const { return x[0] == 0.0 && x[1] <= 0.0; }
  // dist(ξ, D) for the half-line D = {ξ1 = 0, ξ2 ≤ 0}: √(ξ1² + max(ξ2, 0)²).
  double DistanceToJumpSet(ConstVecRef x) const { return std::hypot(x[0], std::max(x[1], 0.0)); }
  void ProjectOntoGuard(int /*guard*/, VecRef x) const { x[0] = 0.0; }
  void FlowJacobian(ConstVecRef /*x*/, ConstVecRef alpha, MatRef jac) const {
    jac << 0.0, alpha[0],  //
        0.0, 0.0;
  }
};

}  // namespace hysid
