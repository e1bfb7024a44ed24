#include "sim/exogenous.hpp"

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

ContextSource::ContextSource(const Model& model, const Exogenous& exo)
    : exo_(exo), u_(model.spec().inputs.size(), 0.0), mode_(InitialMode(model, exo)) {}

Context ContextSource::At(double t) {
  Context ctx;
  ctx.t = t;
  if (exo_.inputs) {
    exo_.inputs->At(t, u_.data(), &hint_);
    ctx.u = u_.data();
  }
  if (exo_.gamma.size() != 0) ctx.gamma = exo_.gamma.data();
  ctx.mode = mode_;
  return ctx;
}

}  // namespace hysid
