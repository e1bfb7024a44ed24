// hysid: identification of hybrid dynamical systems from sampled states.
// Subcommands: models, simulate, identify, reproduce, sweep, merge, crlb, compare. `hysid --help` lists them.
#include <cstdio>
#include <exception>

#include "core/builtin/builtin.hpp"
#include "core/model/registry.hpp"
#include "experiments/cli/entry.hpp"

int main(int argc, char** argv) {
  hysid::ModelRegistry registry;
  try {
    hysid::RegisterBuiltinModels(registry);
  } catch (const std::exception& e) {  // e.g. a bad HYSID_* variable read while the models are built
    std::fprintf(stderr, "hysid: error: %s\n", e.what());
    return 2;
  }
  return hysid::cli::Main(argc, argv, std::move(registry));
}
