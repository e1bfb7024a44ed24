// Registering the built-in models: impact-msd, bouncing-ball, impact-pendulum.
#pragma once

#include "core/model/registry.hpp"

namespace hysid {

void RegisterBuiltinModels(ModelRegistry& registry);

}  // namespace hysid
