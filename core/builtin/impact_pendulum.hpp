// A damped pendulum θ'' = −a sin θ − b θ' swinging against a wall at θ = 0 (restitution λ, impact
// term μ). φ is nonlinear in the state, so the flow Jacobian depends on ξ.
//   ξ = (θ, ω),  ξ' = [ξ2; −a sin ξ1 − bξ2] = φ(ξ)α,  φ = [[ξ2, 0, 0], [0, −sin ξ1, −ξ2]],  α = (1, a, b)
//   ξ+ = [ξ1; −λξ2 + μ] = ψ(ξ)β,                      ψ = [[ξ1, 0, 0], [0, −ξ2, 1]],       β = (1, λ, μ)
//   C = {ξ1 ≥ 0} \ {ξ1 = 0, ξ2 < 0},  D = {ξ1 = 0, ξ2 ≤ 0}
#pragma once

#include "core/builtin/spec.hpp"
#include "core/builtin/wall_oscillator.hpp"

namespace hysid {

struct ImpactPendulum : WallOscillator<Gravity> {
  ModelSpec Spec() const { return BuiltinSpec("impact-pendulum"); }  // models/impact-pendulum.toml
};

}  // namespace hysid
