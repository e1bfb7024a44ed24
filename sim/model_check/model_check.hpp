// Model files as the programs load them: read and checked by core/model_file, then the default
// trajectory (defaults.x0, t_end, dt) simulated and every guard checked to reach D on it at least once.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include "core/model/model.hpp"

namespace hysid {

// What the file's values are. kTruth (simulate, crlb, sweep): the system itself, so a guard its
// default trajectory never reaches is refused. kStart (identify): start values of a fit, which
// places the switches from the data; such a guard is a note, not an error.
enum class ModelValues { kTruth, kStart };

// Throws std::invalid_argument "FILE:LINE: KEY: problem" (or "FILE: ..." when the file cannot be read).
// With kStart, `note` (when given) receives the guard that is not reached, or "".
Model LoadModelFile(const std::filesystem::path& path, ModelValues values = ModelValues::kTruth,
                    std::string* note = nullptr);
// The same from text; `name` stands for the file in errors.
Model ParseModelText(std::string_view text, const std::string& name, ModelValues values = ModelValues::kTruth,
                     std::string* note = nullptr);

}  // namespace hysid
