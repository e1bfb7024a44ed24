// The inputs of a model file's `input_defaults` at the sample times k·δt of a grid, as `hysid simulate`
// gives them to a run (empty for a model without inputs).
#pragma once

#include "core/model_file/input_defaults.hpp"
#include "sim/input_signal.hpp"
#include "sim/simulator.hpp"

namespace hysid {

inline InputSignal DefaultInputs(const Model& model, const SampleGrid& grid) {
  InputSignal inputs;
  if (model.input_size() == 0) return inputs;
  for (long k = 0; k < grid.size(); ++k) inputs.times.push_back(static_cast<double>(k) * grid.dt);
  inputs.values = EvaluateInputDefaults(model.spec(), inputs.times);
  return inputs;
}

}  // namespace hysid
