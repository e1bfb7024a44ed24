// What a run needs besides the model, its initial state and its parameters α, β: the guard
// parameters γ and the measured inputs u(t). Simulate, the run loop and the sensitivities take one;
// the default (no γ given, no inputs) is the paper's class.
#pragma once

#include <string>
#include <vector>

#include "core/model/context.hpp"
#include "core/model/model.hpp"
#include "sim/input_signal.hpp"

namespace hysid {

struct Exogenous {
  Vec gamma;                            // guard parameters γ (|γ| entries); empty: the model's own
  const InputSignal* inputs = nullptr;  // measured inputs u(t); nullptr: the model has none
  int initial_mode = -1;                // q0 of a hybrid automaton; −1: ModelSpec::default_mode
};

// q0 of a run: exo.initial_mode, or the model's default_mode when it is −1.
int InitialMode(const Model& model, const Exogenous& exo);

// "" when `exo` fits `model` on the run time range [0, t_end]: γ empty or one finite entry per guard
// parameter; initial_mode −1 or a mode of the model ([0, ModeCount)); inputs given exactly when the model has inputs, with one row per input, sound
// (InputSignalError) and covering [0, t_end] (InputRangeError). Else why, naming what disagrees.
std::string ExogenousError(const Model& model, const Exogenous& exo, double t_end);

// The Context of a time: u(t) interpolated into a buffer of its own, γ from the Exogenous (or the
// model's own), the run's α and β (the guards and sets may read them; nullptr: the model's own), the
// mode set last (set_mode; the run loop's current mode). One per run (not shared between threads); a
// Context it returns points into its buffer and is valid until its next At().
class ContextSource {
 public:
  ContextSource(const Model& model, const Exogenous& exo, const Vec* alpha = nullptr, const Vec* beta = nullptr);
  Context At(double t);
  // ∂h/∂t at (x, ctx) with ξ held and u(t) moving (the time and the inputs of ctx replaced): central
  // differences over t ± 1e-6·max(1, |t|); zero, bit for bit, for guards that read neither. ctx may come
  // from this source's At(ctx.t): its inputs are u(ctx.t) again on return.
  void GuardTimeDerivative(const Model& model, const ConstVecRef& x, const Context& ctx, VecRef dh_dt);
  // The mode every later At() carries in Context::mode.
  void set_mode(int mode) { mode_ = mode; }
  int mode() const { return mode_; }

 private:
  const Exogenous& exo_;
  const Vec* alpha_;
  const Vec* beta_;
  std::vector<double> u_;
  long hint_ = 0;  // the input interval of the last At
  int mode_ = 0;
};

}  // namespace hysid
