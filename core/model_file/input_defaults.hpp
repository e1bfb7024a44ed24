// The default inputs of a model file: per input an expression of t (`input_defaults = { u = "..." }`,
// ModelSpec::input_defaults), evaluated with muParser at the sample times of a run. `hysid simulate`
// uses them when no input file is given.
#pragma once

#include <string>
#include <vector>

#include "core/model/model.hpp"

namespace hysid {

// "" when every input has a default expression, else the inputs without one (comma-separated).
std::string InputsWithoutDefault(const ModelSpec& spec);

// The default inputs at `times`: m × K, column k = u(times[k]). Throws std::invalid_argument naming
// `input_defaults.NAME` for an input without an expression, one that does not parse (muParser's
// message), or a value that is not finite (with its t).
Mat EvaluateInputDefaults(const ModelSpec& spec, const std::vector<double>& times);

}  // namespace hysid
