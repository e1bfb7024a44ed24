// A damped pendulum θ'' = −a sin θ − b θ' swinging against a wall at θ = 0 (restitution λ, impact
// term μ). φ is nonlinear in the state, so the flow Jacobian depends on ξ.
//   ξ = (θ, ω),  ξ' = [ξ2; −a sin ξ1 − bξ2] = φ(ξ)α,  φ = [[ξ2, 0, 0], [0, −sin ξ1, −ξ2]],  α = (1, a, b)
//   ξ+ = [ξ1; −λξ2 + μ] = ψ(ξ)β,                      ψ = [[ξ1, 0, 0], [0, −ξ2, 1]],       β = (1, λ, μ)
//   C = {ξ1 ≥ 0} \ {ξ1 = 0, ξ2 < 0},  D = {ξ1 = 0, ξ2 ≤ 0}
#pragma once

#include <algorithm>
#include <cmath>

#include "core/model/model.hpp"

namespace hysid {

struct ImpactPendulum {
  ModelSpec Spec() const {
    return ModelSpec{
        .name = "impact-pendulum",
        .description = "damped pendulum against a wall at theta = 0 (nonlinear flow)",
        .state_names = {"theta", "omega"},
        .alpha = {{"alpha_theta", 1.0, true, "coefficient of omega in theta' (known)"},
                  {"a", 9.81, false, "g / length"},
                  {"b", 0.1, false, "damping coefficient"}},
        .beta = {{"beta_theta", 1.0, true, "coefficient of theta in theta+ (known)"},
                 {"lambda", 0.9, false, "restitution coefficient"},
                 {"mu", 0.0, false, "additive impact term"}},
        .flow_rows = {1},
        .jump_rows = {1},
        .guards = {{"wall", Crossing::kFalling}},
        .flow_jacobian_constant = false,
        .default_x0 = {1.2, 0.0},
        .default_t_end = 20.0,
        .default_dt = 1e-3,
        .equations =
            "flow: theta' = alpha_theta*omega, omega' = -a*sin(theta) - b*omega\n"
            "jump: theta+ = beta_theta*theta, omega+ = -lambda*omega + mu\n"
            "guard wall: h(xi) = theta (falling)\n"
            "C: theta > 0 || (theta == 0 && omega >= 0)\n"
            "D: theta == 0 && omega <= 0\n",
    };
  }
  void Phi(ConstVecRef x, MatRef phi) const {
    phi << x[1], 0.0, 0.0,  //
        0.0, -std::sin(x[0]), -x[1];
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
  void FlowJacobian(ConstVecRef x, ConstVecRef alpha, MatRef jac) const {
    jac << 0.0, alpha[0],  //
        -alpha[1] * std::cos(x[0]), -alpha[2];
  }
};

}  // namespace hysid
