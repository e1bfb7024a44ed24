// hysid: identification of hybrid dynamical systems from sampled states.
// Subcommands: models, simulate, identify, reproduce, sweep, merge, crlb. `hysid --help` lists them.
#include "core/builtin/builtin.hpp"
#include "core/model/registry.hpp"
#include "experiments/cli/entry.hpp"

int main(int argc, char** argv) {
  hysid::ModelRegistry registry;
  hysid::RegisterBuiltinModels(registry);
  return hysid::cli::Main(argc, argv, std::move(registry));
}
