// The paper's §5 impact mass-spring-damper: unit mass on a spring (stiffness a) with damping b,
// hitting a wall at x = 0 with restitution λ and an additive impact term μ.
//   ξ = (x, x'),  ξ' = [ξ2; −aξ1 − bξ2] = φ(ξ)α,  φ = [[ξ2, 0, 0], [0, −ξ1, −ξ2]],  α = (1, a, b)
//   ξ+ = [ξ1; −λξ2 + μ] = ψ(ξ)β,               ψ = [[ξ1, 0, 0], [0, −ξ2, 1]],   β = (1, λ, μ)
//   C = {ξ1 ≥ 0} \ {ξ1 = 0, ξ2 < 0},  D = {ξ1 = 0, ξ2 ≤ 0}
#pragma once

#include <string>

#include "core/model/builtin/wall_impact.hpp"

namespace hysid {

struct ImpactMsd : WallImpact {
  ModelSpec Spec() const {
    return ModelSpec{
        .name = "impact-msd",
        .description = "impact mass-spring-damper of the paper's Sec. 5",
        .state_names = {"x", "v"},
        .alpha = {{"alpha_x", 1.0, true, "coefficient of v in x' (known)"},
                  {"a", 5.0, false, "spring stiffness"},
                  {"b", 0.1, false, "damping coefficient"}},
        .beta = JumpParameters("x", 0.99),
        .flow_rows = {1},
        .jump_rows = {1},
        .guards = {{"wall", Crossing::kFalling}},
        .flow_jacobian_constant = true,
        .default_x0 = {20.0, 0.0},
        .default_t_end = 20.0,
        .default_dt = 5e-4,
        .equations = std::string("flow: x' = alpha_x*v, v' = -a*x - b*v\n") + JumpEquations("x", "v", "wall"),
    };
  }
  void Phi(ConstVecRef x, MatRef phi) const {
    SetRowMajor<2, 3>(phi, {x[1], 0.0, 0.0,  //
                            0.0, -x[0], -x[1]});
  }
  void FlowJacobian(ConstVecRef /*x*/, ConstVecRef alpha, MatRef jac) const {
    SetRowMajor<2, 2>(jac, {0.0, alpha[0],  //
                            -alpha[1], -alpha[2]});
  }
};

}  // namespace hysid
