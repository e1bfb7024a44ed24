#include "experiments/cli/entry.hpp"

#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>

#include "experiments/cli/cli.hpp"
#include "hysid_git_revision.h"  // generated at build time (cmake/git_revision.cmake)

namespace hysid::cli {

int Main(int argc, char** argv, ModelRegistry registry) {
  Environment env{std::move(registry)};
  CLI::App app{"hysid: identify hybrid dynamical systems from sampled states", "hysid"};
  app.require_subcommand(1);
  app.set_version_flag("--version", HYSID_VERSION " (" HYSID_GIT_REVISION ")");
  AddSimulateCommand(app, env);
  AddModelsCommand(app, env);
  AddIdentifyCommand(app, env);
  AddReproduceCommand(app, env);
  AddSweepCommand(app, env);
  AddCrlbCommand(app, env);

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
    return 2;  // usage: CLI11's own codes (105, 108, ...) are not part of hysid's exit-code policy
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hysid: error: %s\n", e.what());
    return 2;
  }
  return 0;
}

}  // namespace hysid::cli
