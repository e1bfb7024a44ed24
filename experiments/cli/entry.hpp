// The public entry point of the hysid command line. A program that adds its own models builds a
// registry (RegisterBuiltinModels, core/builtin/builtin.hpp, plus its own Register calls) and returns
// Main(argc, argv, registry): every subcommand (models, simulate, identify, reproduce, sweep, merge) then
// knows those models by name.
#pragma once

#include "core/model/registry.hpp"

namespace hysid::cli {

// Parses argv, runs the subcommand and returns the exit code: 0 success, 1 a run that finished with
// a failed status, 2 bad input or usage (the reason on stderr, one line), 130 interrupted (128 + the
// signal: core/io/signals.hpp; a closed output pipe ends the process by SIGPIPE).
int Main(int argc, char** argv, ModelRegistry registry);

}  // namespace hysid::cli
