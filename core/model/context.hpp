// Where a model function is evaluated besides the state ξ: the time t, the measured inputs u(t) and
// the guard parameters γ (docs/architecture.md "Systems as measured and hybrid automata").
#pragma once

namespace hysid {

struct Context {
  double t = 0.0;
  // ModelSpec::inputs.size() values; nullptr only for a model without inputs.
  const double* u = nullptr;
  // ModelSpec::guard_params.size() values; nullptr: the Model's own (true) γ.
  const double* gamma = nullptr;
};

}  // namespace hysid
