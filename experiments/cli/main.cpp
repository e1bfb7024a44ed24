// hysid: identification of hybrid dynamical systems from sampled states.
// Subcommands: models, simulate, identify, reproduce, sweep, merge, crlb. `hysid --help` lists them.
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>

#include "experiments/cli/cli.hpp"
#include "hysid_git_revision.h"  // generated at build time (cmake/git_revision.cmake)

int main(int argc, char** argv) {
  hysid::cli::Environment env;
  hysid::RegisterBuiltinModels(env.models);

  CLI::App app{"hysid: identify hybrid dynamical systems from sampled states", "hysid"};
  app.require_subcommand(1);
  app.set_version_flag("--version", HYSID_VERSION " (" HYSID_GIT_REVISION ")");
  hysid::cli::AddSimulateCommand(app, env);
  hysid::cli::AddModelsCommand(app, env);
  hysid::cli::AddIdentifyCommand(app, env);
  hysid::cli::AddReproduceCommand(app, env);
  hysid::cli::AddSweepCommand(app, env);
  hysid::cli::AddCrlbCommand(app, env);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::RuntimeError& e) {
    return e.get_exit_code();  // a run that finished with a status that is not ok (already printed)
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "hysid: error: %s\n", e.what());
    return e.get_exit_code() == 0 ? 2 : e.get_exit_code();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hysid: error: %s\n", e.what());
    return 2;
  }
  return 0;
}
