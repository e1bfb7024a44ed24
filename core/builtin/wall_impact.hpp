// The impact the built-in models share: a wall (or floor) at ξ1 = 0 hit from above, with restitution
// λ and an additive impact term μ.
//   ξ+ = [ξ1; −λξ2 + μ] = ψ(ξ)β,  ψ = [[ξ1, 0, 0], [0, −ξ2, 1]],  β = (1, λ, μ)
//   guard h(ξ) = ξ1 (falling),  C = {ξ1 ≥ 0} \ {ξ1 = 0, ξ2 < 0},  D = {ξ1 = 0, ξ2 ≤ 0}
// A model derives from it (or from WallOscillator) and adds its spec (from its model file) and its
// flow (Phi, FlowJacobian).
#pragma once

#include <algorithm>
#include <cmath>

#include "core/model/model.hpp"

namespace hysid {

struct WallImpact {
  void Psi(ConstVecRef x, MatRef psi) const {
    SetRowMajor<2, 3>(psi, {x[0], 0.0, 0.0,  //
                            0.0, -x[1], 1.0});
  }
  void Guards(ConstVecRef x, VecRef h) const { h[0] = x[0]; }
  bool InFlowSet(ConstVecRef x) const { return x[0] > 0.0 || (x[0] == 0.0 && x[1] >= 0.0); }
  bool InJumpSet(ConstVecRef x) const { return x[0] == 0.0 && x[1] <= 0.0; }
  // dist(ξ, D) for the half-line D = {ξ1 = 0, ξ2 ≤ 0}: √(ξ1² + max(ξ2, 0)²).
  double DistanceToJumpSet(ConstVecRef x) const { return std::hypot(x[0], std::max(x[1], 0.0)); }
  void ProjectOntoGuard(int /*guard*/, VecRef x) const { x[0] = 0.0; }
};

}  // namespace hysid
