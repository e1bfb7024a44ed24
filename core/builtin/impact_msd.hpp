// The paper's §5 impact mass-spring-damper: unit mass on a spring (stiffness a) with damping b,
// hitting a wall at x = 0 with restitution λ and an additive impact term μ.
//   ξ = (x, x'),  ξ' = [ξ2; −aξ1 − bξ2] = φ(ξ)α,  φ = [[ξ2, 0, 0], [0, −ξ1, −ξ2]],  α = (1, a, b)
//   ξ+ = [ξ1; −λξ2 + μ] = ψ(ξ)β,               ψ = [[ξ1, 0, 0], [0, −ξ2, 1]],   β = (1, λ, μ)
//   C = {ξ1 ≥ 0} \ {ξ1 = 0, ξ2 < 0},  D = {ξ1 = 0, ξ2 ≤ 0}
#pragma once

#include "core/builtin/spec.hpp"
#include "core/builtin/wall_oscillator.hpp"

namespace hysid {

struct ImpactMsd : WallOscillator<Spring> {
  ModelSpec Spec() const { return BuiltinSpec("impact-msd"); }  // models/impact-msd.toml
};

}  // namespace hysid
