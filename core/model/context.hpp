// Where a model function is evaluated besides the state ξ: the time t, the measured inputs u(t), the
// guard parameters γ, and for a hybrid automaton the discrete mode q and the jump map being applied
// (docs/architecture.md "Systems as measured and hybrid automata").
#pragma once

namespace hysid {

struct Context {
  double t = 0.0;
  // ModelSpec::inputs.size() values; nullptr only for a model without inputs.
  const double* u = nullptr;
  // ModelSpec::guard_params.size() values; nullptr: the Model's own (true) γ.
  const double* gamma = nullptr;
  // The discrete mode q ∈ [0, ModeCount): selects φ_q in Phi and Flow (0 for a one-mode model).
  int mode = 0;
  // The jump map ∈ [0, JumpMapCount) that Psi and Jump evaluate (0 for a one-map model).
  int map = 0;
};

}  // namespace hysid
