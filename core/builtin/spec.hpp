// The spec of a built-in model, read from its model file (docs/architecture.md, "Built-in models").
#pragma once

#include <string_view>

#include "core/model/model.hpp"

namespace hysid {

// The spec of the built-in model `name` as its file models/NAME.toml states it (parsed once per
// process). Throws std::invalid_argument when there is no built-in model of that name.
const ModelSpec& BuiltinSpec(std::string_view name);

}  // namespace hysid
