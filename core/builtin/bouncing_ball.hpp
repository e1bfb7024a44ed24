// A ball under gravity g bouncing on the floor h = 0 with restitution λ and impact term μ.
// The flow is affine: f(0) = (0, −g) ≠ 0, so Assumption 2.3 of the paper does not hold.
//   ξ = (h, v),  ξ' = [ξ2; −g] = φ(ξ)α,  φ = [[ξ2, 0], [0, −1]],  α = (1, g)
//   ξ+ = [ξ1; −λξ2 + μ] = ψ(ξ)β,          ψ = [[ξ1, 0, 0], [0, −ξ2, 1]],  β = (1, λ, μ)
//   C = {ξ1 ≥ 0} \ {ξ1 = 0, ξ2 < 0},  D = {ξ1 = 0, ξ2 ≤ 0}
// With μ = 0 and λ < 1 the impacts accumulate (Zeno) at
//   t_Z = √(2h0/g) + 2λ√(2gh0) / (g(1 − λ))   for ξ(0) = (h0, 0).
#pragma once

#include "core/builtin/spec.hpp"
#include "core/builtin/wall_impact.hpp"

namespace hysid {

struct BouncingBall : WallImpact {
  ModelSpec Spec() const { return BuiltinSpec("bouncing-ball"); }  // models/bouncing-ball.toml
  void Phi(ConstVecRef x, MatRef phi) const {
    SetRowMajor<2, 2>(phi, {x[1], 0.0,  //
                            0.0, -1.0});
  }
  void FlowJacobian(ConstVecRef /*x*/, ConstVecRef alpha, MatRef jac) const {
    SetRowMajor<2, 2>(jac, {0.0, alpha[0],  //
                            0.0, 0.0});
  }
};

}  // namespace hysid
