// A damped pendulum θ'' = −a sin θ − b θ' swinging against a wall at θ = 0 (restitution λ, impact
// term μ). φ is nonlinear in the state, so the flow Jacobian depends on ξ.
//   ξ = (θ, ω),  ξ' = [ξ2; −a sin ξ1 − bξ2] = φ(ξ)α,  φ = [[ξ2, 0, 0], [0, −sin ξ1, −ξ2]],  α = (1, a, b)
//   ξ+ = [ξ1; −λξ2 + μ] = ψ(ξ)β,                      ψ = [[ξ1, 0, 0], [0, −ξ2, 1]],       β = (1, λ, μ)
//   C = {ξ1 ≥ 0} \ {ξ1 = 0, ξ2 < 0},  D = {ξ1 = 0, ξ2 ≤ 0}
#pragma once

#include <cmath>
#include <string>

#include "core/model/builtin/wall_impact.hpp"

namespace hysid {

struct ImpactPendulum : WallImpact {
  ModelSpec Spec() const {
    return ModelSpec{
        .name = "impact-pendulum",
        .description = "damped pendulum against a wall at theta = 0 (nonlinear flow)",
        .state_names = {"theta", "omega"},
        .alpha = {{"alpha_theta", 1.0, true, "coefficient of omega in theta' (known)"},
                  {"a", 9.81, false, "g / length"},
                  {"b", 0.1, false, "damping coefficient"}},
        .beta = JumpParameters("theta", 0.9),
        .flow_rows = {1},
        .jump_rows = {1},
        .guards = {{"wall", Crossing::kFalling}},
        .flow_jacobian_constant = false,
        .default_x0 = {1.2, 0.0},
        .default_t_end = 20.0,
        .default_dt = 1e-3,
        .equations = std::string("flow: theta' = alpha_theta*omega, omega' = -a*sin(theta) - b*omega\n") +
                     JumpEquations("theta", "omega", "wall"),
    };
  }
  void Phi(ConstVecRef x, MatRef phi) const {
    SetRowMajor<2, 3>(phi, {x[1], 0.0, 0.0,  //
                            0.0, -std::sin(x[0]), -x[1]});
  }
  void FlowJacobian(ConstVecRef x, ConstVecRef alpha, MatRef jac) const {
    SetRowMajor<2, 2>(jac, {0.0, alpha[0],  //
                            -alpha[1] * std::cos(x[0]), -alpha[2]});
  }
};

}  // namespace hysid
