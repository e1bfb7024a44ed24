// The flow impact-msd and impact-pendulum share: a damped oscillator with restoring force a·s(ξ1),
// s(ξ1) = ξ1 (a spring, Spring) or sin ξ1 (gravity on a pendulum, Gravity), against the wall of
// WallImpact.
//   ξ = (ξ1, ξ2),  ξ' = [ξ2; −a s(ξ1) − bξ2] = φ(ξ)α,  φ = [[ξ2, 0, 0], [0, −s(ξ1), −ξ2]],  α = (1, a, b)
//   ∂(φα)/∂ξ = [[0, α1], [−α2 s'(ξ1), −α3]]
// A model derives from WallOscillator<S> and adds its spec (from its model file).
#pragma once

#include <cmath>

#include "core/builtin/wall_impact.hpp"

namespace hysid {

struct Spring {
  static double Force(double x) { return x; }
  static double Slope(double /*x*/) { return 1.0; }
};

struct Gravity {
  static double Force(double x) { return std::sin(x); }
  static double Slope(double x) { return std::cos(x); }
};

template <class Restoring>
struct WallOscillator : WallImpact {
  void Phi(ConstVecRef x, MatRef phi) const {
    SetRowMajor<2, 3>(phi, {x[1], 0.0, 0.0,  //
                            0.0, -Restoring::Force(x[0]), -x[1]});
  }
  void FlowJacobian(ConstVecRef x, ConstVecRef alpha, MatRef jac) const {
    SetRowMajor<2, 2>(jac, {0.0, alpha[0],  //
                            -alpha[1] * Restoring::Slope(x[0]), -alpha[2]});
  }
};

}  // namespace hysid
