// Model files: a TOML file that describes a hybrid model completely (states, parameters, φ and ψ as
// matrices of expressions in the states, identified rows, guards, C, D, defaults), evaluated with
// muParser. The result is an ordinary hysid::Model. docs/model-files.md has the format.
//
// What can be checked without simulating is checked here; the programs load model files through
// sim/model_check/model_check.hpp, which also simulates the default trajectory.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "core/model/model.hpp"

namespace hysid {

struct ModelFile {
  Model model;
  // Per guard, "FILE:LINE: guard[g].h": where a message about the guard points.
  std::vector<std::string> guard_where;
};

// Reads, compiles and checks a model file (its default x0 must lie in C ∪ D). Throws
// std::invalid_argument "FILE:LINE: KEY: problem" (or "FILE: ..." when the file cannot be read).
ModelFile ReadModelFile(const std::filesystem::path& path);
// The same from text; `name` stands for the file in errors. `shipped`: a text built into hysid (the
// built-in models), whose default trajectory is not held to the samples limit (HYSID_MAX_SAMPLES).
ModelFile ParseModelFile(std::string_view text, const std::string& name, bool shipped = false);

}  // namespace hysid
