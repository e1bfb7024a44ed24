// Where a model function is evaluated besides the state ξ: the time t, the measured inputs u(t), the
// guard parameters γ, the flow and jump parameters α and β (which guards and sets may read), and for a
// hybrid automaton the discrete mode q and the jump map being applied (docs/architecture.md "Systems as
// measured and hybrid automata").
#pragma once

namespace hysid {

struct Context {
  double t = 0.0;
  // ModelSpec::inputs.size() values; nullptr only for a model without inputs.
  const double* u = nullptr;
  // ModelSpec::guard_params.size() values; nullptr: the Model's own (true) γ.
  const double* gamma = nullptr;
  // The run's α (|α| values) and β (|β| values), which the guards and sets of a model file may read by
  // name; nullptr: the Model's own. φ and ψ take α and β as arguments and never read these.
  const double* alpha = nullptr;
  const double* beta = nullptr;
  // The discrete mode q ∈ [0, ModeCount): selects φ_q in Phi and Flow (0 for a one-mode model).
  int mode = 0;
  // The jump map ∈ [0, JumpMapCount) that Psi and Jump evaluate (0 for a one-map model).
  int map = 0;
};

}  // namespace hysid
