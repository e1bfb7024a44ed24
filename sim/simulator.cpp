#include "sim/simulator.hpp"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "sim/hybrid_run.hpp"

namespace hysid {

long SampleGrid::size() const { return static_cast<long>(std::floor(t_end / dt + 1e-9)) + 1; }

SampleGrid EvenGrid(double t_end, long count) {
  const auto steps = static_cast<double>(count - 1);
  double dt = t_end / steps;
  while (steps * dt > t_end) dt = std::nextafter(dt, 0.0);
  return SampleGrid{.t_end = t_end, .dt = dt};
}

bool SampleGrid::IsValid(std::string* error) const {
  auto fail = [&](const std::string& what) {
    if (error) *error = what;
    return false;
  };
  if (!std::isfinite(dt) || !(dt > 0.0)) {
    return fail(fmt::format("SampleGrid::dt = {}. Violated constraint: dt > 0 and finite", dt));
  }
  if (!std::isfinite(t_end) || !(t_end > 0.0)) {
    return fail(fmt::format("SampleGrid::t_end = {}. Violated constraint: t_end > 0 and finite", t_end));
  }
  if (t_end / dt > 1e9) {
    return fail(
        fmt::format("SampleGrid: t_end/dt = {:.3g}. Violated constraint: at most 1e9 "
                    "samples",
                    t_end / dt));
  }
  return true;
}

bool SimOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& what) {
    if (error) *error = what;
    return false;
  };
  if (!(rtol > 0.0) || !std::isfinite(rtol)) {
    return fail(fmt::format("SimOptions::rtol = {}. Violated constraint: rtol > 0", rtol));
  }
  if (!(atol > 0.0) || !std::isfinite(atol)) {
    return fail(fmt::format("SimOptions::atol = {}. Violated constraint: atol > 0", atol));
  }
  if (max_steps < 1) {
    return fail(fmt::format("SimOptions::max_steps = {}. Violated constraint: max_steps >= 1", max_steps));
  }
  if (!(input_kink >= 0.0) || !std::isfinite(input_kink)) {
    return fail(fmt::format("SimOptions::input_kink = {}. Violated constraint: input_kink >= 0 and finite",
                            input_kink));
  }
  if (max_jumps < 1) {
    return fail(fmt::format("SimOptions::max_jumps = {}. Violated constraint: max_jumps >= 1", max_jumps));
  }
  if (!(zeno_interval >= 0.0)) {
    return fail(fmt::format("SimOptions::zeno_interval = {}. Violated constraint: zeno_interval >= 0",
                            zeno_interval));
  }
  if (zeno_window < 1) {
    return fail(
        fmt::format("SimOptions::zeno_window = {}. Violated constraint: zeno_window >= 1", zeno_window));
  }
  if (max_jumps_at_one_time < 1) {
    return fail(fmt::format("SimOptions::max_jumps_at_one_time = {}. Violated constraint: >= 1",
                            max_jumps_at_one_time));
  }
  return true;
}

const char* ToString(SimStop stop) {
  switch (stop) {
    case SimStop::kCompleted: return "completed";
    case SimStop::kZeno: return "zeno";
    case SimStop::kJumpBudget: return "jump-budget";
    case SimStop::kSolverFailure: return "solver-failure";
    case SimStop::kNonFinite: return "non-finite";
    case SimStop::kLeftDomain: return "left-domain";
  }
  return "unknown";
}

Trajectory Simulate(const Model& model, const Vec& x0, const SampleGrid& grid, const SimOptions& options,
                    const Exogenous& exo) {
  std::string error;
  if (!grid.IsValid(&error) || !options.IsValid(&error)) throw std::invalid_argument(error);
  if (x0.size() != model.state_size()) {
    throw std::invalid_argument(fmt::format("x0 has {} entries; model '{}' has {} states", x0.size(),
                                            model.name(), model.state_size()));
  }
  if (!x0.allFinite()) throw std::invalid_argument("x0 is not finite");
  const hybrid::SampleTimes samples{.count = grid.size(), .dt = grid.dt};
  if (std::string why = ExogenousError(model, exo, samples.at(samples.count - 1)); !why.empty()) {
    throw std::invalid_argument(why);
  }
  ContextSource context(model, exo);
  if (!model.InFlowSet(x0, context.At(0.0)) && !model.InJumpSet(x0, context.At(0.0))) {
    throw std::invalid_argument(fmt::format("x0 lies outside C and D of model '{}'", model.name()));
  }
  hybrid::Engine engine(model, model.alpha(), model.beta(), exo, samples, options, /*payload=*/nullptr);
  return engine.Run(x0);
}

}  // namespace hysid
