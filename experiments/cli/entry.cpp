#include "experiments/cli/entry.hpp"

// Exit codes (docs/architecture.md "Robustness"): 0 success, 1 a run that finished with a failed
// status, 2 bad input or usage, 130 interrupted (143 by SIGTERM, 129 by SIGHUP; core/io/signals.hpp).
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/io/files.hpp"
#include "core/io/limits.hpp"
#include "core/io/signals.hpp"
#include "experiments/cli/cli.hpp"
#include "hysid_git_revision.h"  // generated at build time (cmake/git_revision.cmake)

namespace hysid::cli {
namespace {

constexpr const char* kExitCodes =
    "Exit codes: 0 success; 1 a run that finished with a failed status (solver failure, Zeno where\n"
    "not expected, fit not ok); 2 bad input or usage; 130 interrupted (SIGINT; 143 SIGTERM, 129 SIGHUP).\n"
    "A closed output pipe (hysid ... | head) ends hysid quietly by SIGPIPE.";

// "hysid frobnicate": CLI11 would say "A subcommand is required"; name the word and the subcommands.
bool UnknownSubcommand(const CLI::App& app, int argc, char** argv) {
  if (argc < 2 || argv[1][0] == '-') return false;
  for (const CLI::App* sub : app.get_subcommands({})) {
    if (sub->get_name() == argv[1]) return false;
  }
  std::vector<std::string> names;
  for (const CLI::App* sub : app.get_subcommands({})) names.push_back(sub->get_name());
  std::fprintf(stderr, "hysid: error: unknown subcommand '%s' (known: %s; see hysid --help)\n",
               Abbreviated(argv[1]).c_str(), fmt::format("{}", fmt::join(names, ", ")).c_str());
  return true;
}

// An empty argument ("--dt ''", "--dt=", an unset shell variable): CLI11 would read it as the default.
bool EmptyArgument(int argc, char** argv) {
  for (int i = 2; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool flag_equals_nothing = arg.starts_with("--") && arg.find('=') == arg.size() - 1;
    if (!arg.empty() && !flag_equals_nothing) continue;
    const bool after_flag = arg.empty() && argv[i - 1][0] == '-' && argv[i - 1][1] != '\0';
    const std::string what = flag_equals_nothing ? arg.substr(0, arg.size() - 1)
                             : after_flag        ? Abbreviated(argv[i - 1])
                                                 : fmt::format("argument {}", i - 1);
    std::fprintf(stderr,
                 "hysid: error: %s: empty; give a value or leave the flag out (see hysid %s --help)\n",
                 what.c_str(), argv[1]);
    return true;
  }
  return false;
}

// Parses and runs; the exit code.
int RunParsed(CLI::App& app, int argc, char** argv) {
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
    // CLI11's own codes (104 conversion, 106 required, 109 extras, ...) are all usage errors.
    std::fprintf(stderr, "hysid: error: %s (see hysid %s--help)\n", ShortenedMessage(e.what(), 300).c_str(),
                 app.get_subcommands().empty() ? "" : (app.get_subcommands()[0]->get_name() + " ").c_str());
    return 2;
  } catch (const RunFailed& e) {
    std::fprintf(stderr, "hysid: %s\n", e.what());
    return e.code();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hysid: error: %s\n", ShortenedMessage(e.what(), 2000).c_str());
    return 2;
  }
  return 0;
}

}  // namespace

int Main(int argc, char** argv, ModelRegistry registry) {
  Environment env{std::move(registry)};
  CLI::App app{"hysid: identify hybrid dynamical systems from sampled states", "hysid"};
  app.require_subcommand(1);
  app.footer(kExitCodes);
  app.set_version_flag("--version", HYSID_VERSION " (" HYSID_GIT_REVISION ")");
  AddSimulateCommand(app, env);
  AddModelsCommand(app, env);
  AddIdentifyCommand(app, env);
  AddReproduceCommand(app, env);
  AddSweepCommand(app, env);
  AddCrlbCommand(app, env);
  AddCompareCommand(app, env);
  // `hysid SUBCOMMAND --version` answers the version too, before the subcommand's required flags.
  for (CLI::App* sub : app.get_subcommands({}))
    sub->set_version_flag("--version", HYSID_VERSION " (" HYSID_GIT_REVISION ")");
  if (UnknownSubcommand(app, argc, argv) || EmptyArgument(argc, argv)) return 2;
  // A signal that ends the process removes the temporary files of the outputs being written.
  InstallSignalCleanup();

  int code = RunParsed(app, argc, argv);
  // Everything printed must have arrived (a full disk, a closed pipe with SIGPIPE ignored).
  if (std::string error; !FlushStandardOutput(&error)) {
    std::fprintf(stderr, "hysid: error: %s\n", error.c_str());
    if (code == 0) code = 2;
  }
  return code;
}

}  // namespace hysid::cli
