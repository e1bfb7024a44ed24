#include "sim/exogenous.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/model/automaton.hpp"

namespace hysid {

std::string ExogenousError(const Model& model, const Exogenous& exo, double t_end) {
  const ModelSpec& spec = model.spec();
  if (exo.gamma.size() != 0) {
    if (exo.gamma.size() != model.gamma_size()) {
      return fmt::format("guard parameters have {} entries; model '{}' has {}", exo.gamma.size(), model.name(),
                         model.gamma_size());
    }
    if (!exo.gamma.allFinite()) return "guard parameters are not finite";
  }
  if (exo.initial_mode < -1 || exo.initial_mode >= ModeCount(spec)) {
    return fmt::format("initial mode {} outside [0, {}) of model '{}'", exo.initial_mode, ModeCount(spec),
                       model.name());
  }
  if (spec.inputs.empty()) {
    if (exo.inputs) return fmt::format("inputs given, but model '{}' has none", model.name());
    return "";
  }
  if (!exo.inputs) {
    return fmt::format("model '{}' has inputs ({}) and none were given", model.name(), fmt::join(spec.inputs, ", "));
  }
  if (exo.inputs->size() != static_cast<int>(spec.inputs.size())) {
    return fmt::format("the input signal has {} rows; model '{}' has {} inputs", exo.inputs->size(), model.name(),
                       spec.inputs.size());
  }
  if (std::string why = InputSignalError(*exo.inputs, "the input signal"); !why.empty()) return why;
  return InputRangeError(*exo.inputs, spec.inputs, 0.0, t_end);
}

int InitialMode(const Model& model, const Exogenous& exo) {
  return exo.initial_mode >= 0 ? exo.initial_mode : model.spec().default_mode;
}

ContextSource::ContextSource(const Model& model, const Exogenous& exo, const Vec* alpha, const Vec* beta)
    : exo_(exo), alpha_(alpha), beta_(beta), u_(model.spec().inputs.size(), 0.0), mode_(InitialMode(model, exo)) {}

Context ContextSource::At(double t) {
  Context ctx;
  ctx.t = t;
  if (exo_.inputs) {
    exo_.inputs->At(t, u_.data(), &hint_);
    ctx.u = u_.data();
  }
  if (exo_.gamma.size() != 0) ctx.gamma = exo_.gamma.data();
  if (alpha_ != nullptr) ctx.alpha = alpha_->data();
  if (beta_ != nullptr) ctx.beta = beta_->data();
  ctx.mode = mode_;
  return ctx;
}

void ContextSource::GuardTimeDerivative(const Model& model, const ConstVecRef& x, const Context& ctx,
                                        VecRef dh_dt) {
  const double step = 1e-6 * std::max(1.0, std::abs(ctx.t));
  Vec hm(model.guard_count());
  Context at = ctx;
  at.t = ctx.t + step;
  at.u = At(at.t).u;
  model.Guards(x, dh_dt, at);
  at.t = ctx.t - step;
  at.u = At(at.t).u;
  model.Guards(x, hm, at);
  dh_dt = (dh_dt - hm) / ((ctx.t + step) - (ctx.t - step));
  At(ctx.t);  // the buffer holds u(ctx.t) again: ctx may point into it
}

}  // namespace hysid
