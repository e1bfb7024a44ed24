// The hysid command line: one subcommand per file, each registered by an Add*Command function.
#pragma once

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "core/identify/identifier.hpp"
#include "core/model/model.hpp"
#include "core/identify/identifier.hpp"
#include "core/io/sample_data.hpp"
#include "core/model/registry.hpp"

namespace hysid::cli {

// Shared by the subcommands.
struct Environment {
  ModelRegistry models;
};

void AddSimulateCommand(CLI::App& app, Environment& env);
void AddModelsCommand(CLI::App& app, Environment& env);
void AddIdentifyCommand(CLI::App& app, Environment& env);
void AddReproduceCommand(CLI::App& app, Environment& env);
void AddSweepCommand(CLI::App& app, Environment& env);  // sweep and merge
void AddCrlbCommand(CLI::App& app, Environment& env);

// hysid identify's refinement flags (--refine, --json) and what runs after the recursive estimate:
// the refinement, the estimates with standard errors (and CRLB ratios when the data carry the
// truth), --json. Returns the exit code: 1 when the refinement ran and its status is not ok.
struct RefineArgs {
  std::string refine = "ml";
  std::string json;
};
void AddRefineOptions(CLI::App* cmd, RefineArgs& args);
int RefineAndReport(const Model& model, const SampleData& data, const IdentifyResult& recursive,
                    const Vec& sigma, const RefineArgs& args);

// A bad flag value: `what` names the flag, e.g. "--dt = -1: must be > 0".
[[noreturn]] void BadFlag(const std::string& what);

// Builds a model from its name and "name=value" assignments; errors name --model / --param.
Model MakeModel(const Environment& env, const std::string& name,
                const std::vector<std::string>& params);
// The same from a model file when `file` is not empty (errors name --model-file), else by name.
Model MakeModel(const Environment& env, const std::string& name, const std::string& file,
                const std::vector<std::string>& params);
// Adds --model-file to a subcommand that has --model (the two exclude each other).
void AddModelFileOption(CLI::App& cmd, std::string& file);

// Checks that every entry is finite; `flag` names the option in the error.
void RequireFinite(const std::string& flag, const std::vector<double>& values);

// --estimator and --detector by name into both estimators' and the detector's kind; errors name the flag.
void SetPluginKinds(const std::string& estimator, const std::string& detector, IdentifierSettings* settings);

// --sigma: one value for every state or one per state, each finite and >= 0.
Vec SigmaFlag(const std::vector<double>& values, int states);

}  // namespace hysid::cli
