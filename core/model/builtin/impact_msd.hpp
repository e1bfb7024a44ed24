// The paper's §5 impact mass-spring-damper: unit mass on a spring (stiffness a) with damping b,
// hitting a wall at x = 0 with restitution λ and an additive impact term μ.
//   ξ = (x, x'),  ξ' = [ξ2; −aξ1 − bξ2] = φ(ξ)α,  φ = [[ξ2, 0, 0], [0, −ξ1, −ξ2]],  α = (1, a, b)
//   ξ+ = [ξ1; −λξ2 + μ] = ψ(ξ)β,               ψ = [[ξ1, 0, 0], [0, −ξ2, 1]],   β = (1, λ, μ)
//   C = {ξ1 ≥ 0} \ {ξ1 = 0, ξ2 < 0},  D = {ξ1 = 0, ξ2 ≤ 0}
#pragma once

#include <algorithm>
#include <cmath>

#include "core/model/model.hpp"

namespace hysid {

struct ImpactMsd {
  ModelSpec Spec() const {
    return ModelSpec{
        .name = "impact-msd",
        .description = "impact mass-spring-damper of the paper's Sec. 5",
        .state_names = {"x", "v"},
        .alpha = {{"alpha_x", 1.0, true, "coefficient of v in x' (known)"},
                  {"a", 5.0, false, "spring stiffness"},
                  {"b", 0.1, false, "damping coefficient"}},
        .beta = {{"beta_x", 1.0, true, "coefficient of x in x+ (known)"},
                 {"lambda", 0.99, false, "restitution coefficient"},
                 {"mu", 0.0, false, "additive impact term"}},
        .flow_rows = {1},
        .jump_rows = {1},
        .guards = {{"wall", Crossing::kFalling}},
        .flow_jacobian_constant = true,
        .default_x0 = {20.0, 0.0},
        .default_t_end = 20.0,
        .default_dt = 5e-4,
        .equations =
            "flow: x' = alpha_x*v, v' = -a*x - b*v\n"
            "jump: x+ = beta_x*x, v+ = -lambda*v + mu\n"
            "guard wall: h(xi) = x (falling)\n"
            "C: x > 0 || (x == 0 && v >= 0)\n"
            "D: x == 0 && v <= 0\n",
    };
  }
  void Phi(ConstVecRef x, MatRef phi) const {
    phi << x[1], 0.0, 0.0,  //
        0.0, -x[0], -x[1];
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
        -alpha[1], -alpha[2];
  }
};

}  // namespace hysid
