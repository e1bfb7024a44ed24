// Model files: a TOML file that describes a hybrid model completely (states, parameters, φ and ψ as
// matrices of expressions in the states, identified rows, guards, C, D, defaults), evaluated with
// muParser. The result is an ordinary hysid::Model. docs/architecture.md "Model files" has the format.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include "core/model/model.hpp"

namespace hysid {

struct ModelFileOptions {
  // Simulate the default trajectory and require every guard to reach D on it at least once.
  bool check_guards = true;
};

// Reads, compiles and checks a model file. Throws std::invalid_argument "FILE:LINE: KEY: problem"
// (or "FILE: ..." when the file cannot be read).
Model LoadModelFile(const std::filesystem::path& path, const ModelFileOptions& options = {});
// The same from text; `name` stands for the file in errors.
Model ParseModelText(std::string_view text, const std::string& name, const ModelFileOptions& options = {});

}  // namespace hysid
