// Model files as the programs load them: read and checked by core/model_file, then the default
// trajectory (defaults.x0, t_end, dt) simulated, and every guard required to reach D on it at least
// once, so that a guard that can never fire is refused before any identification.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include "core/model/model.hpp"

namespace hysid {

// Throws std::invalid_argument "FILE:LINE: KEY: problem" (or "FILE: ..." when the file cannot be read).
Model LoadModelFile(const std::filesystem::path& path);
// The same from text; `name` stands for the file in errors.
Model ParseModelText(std::string_view text, const std::string& name);

}  // namespace hysid
