// The hysid command line: one subcommand per file, each registered by an Add*Command function.
#pragma once

#include <atomic>
#include <charconv>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json_fwd.hpp>

#include "core/identify/identifier.hpp"
#include "core/io/sample_data.hpp"
#include "core/model/model.hpp"
#include "core/model/registry.hpp"
#include "experiments/request/checks.hpp"
#include "experiments/request/request.hpp"
#include "experiments/request/settings.hpp"
#include "sim/model_check/model_check.hpp"
#include "sim/events/fitted_events.hpp"
#include "sim/events/fitted_outputs.hpp"
#include "sim/refine/refine.hpp"
#include "sim/sensitivity/crlb.hpp"
#include "sim/simulator.hpp"
#include "experiments/sweep/progress.hpp"

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
void AddCompareCommand(CLI::App& app, Environment& env);

// A run that finished with a failed status (exit 1) or was interrupted (exit 130): thrown after
// the outputs are written, so that `main` returns the code and destructors still run.
class RunFailed : public std::runtime_error {
 public:
  RunFailed(const std::string& what, int code = 1) : std::runtime_error(what), code_(code) {}
  int code() const { return code_; }

 private:
  int code_;
};

// A bad flag value: `what` names the flag, e.g. "--dt = -1: must be > 0".
[[noreturn]] void BadFlag(const std::string& what);
// --progress: auto, bar, lines or none (BadFlag naming the flag otherwise).
Progress::Mode ProgressFlag(const std::string& text);

// Builds a model from its name and "name=value" assignments; errors name --model / --param.
Model MakeModel(const Environment& env, const std::string& name, const std::vector<std::string>& params);
// The same from a model file when `file` is not empty (errors name --model-file), else by name; a file's
// values are checked as `values` says (sim/model_check), a kStart note put in `note` when given.
Model MakeModel(const Environment& env, const std::string& name, const std::string& file,
                const std::vector<std::string>& params, ModelValues values = ModelValues::kTruth,
                std::string* note = nullptr);
// --model, --model-file (instead of --model) and --param of a subcommand that runs one model.
struct ModelFlags {
  std::string name = "impact-msd";
  std::string file;
  std::vector<std::string> params;
};
// Adds the three flags to `cmd`; `param_help` is --param's help.
void AddModelFlags(CLI::App& cmd, ModelFlags& flags, const std::string& param_help);
// The model the flags name; errors name --model, --model-file or --param.
Model MakeModel(const Environment& env, const ModelFlags& flags, ModelValues values = ModelValues::kTruth,
                std::string* note = nullptr);

// --param-bound NAME=LO,HI (repeatable) of crlb (identify's comes from its settings table; not --bound:
// the paper detector's bound mode has that flag), and the bounds it sets on the model
// (Model::SetBounds); errors name --param-bound: malformed text, a name given twice or unknown, a known
// constant, LO >= HI, or the model's value outside [LO, HI].
void AddBoundFlag(CLI::App& cmd, std::vector<std::string>& bounds);
void ApplyBoundFlags(const std::vector<std::string>& bounds, Model* model);

// --x0, --t-end and --dt of a subcommand that simulates one trajectory; each not given means the
// model's default (ModelSpec::default_x0, default_t_end, default_dt).
struct TrajectoryFlags {
  std::vector<double> x0;
  std::optional<double> t_end, dt;
};
void AddTrajectoryFlags(CLI::App& cmd, TrajectoryFlags& flags);
// The inputs of a run over `grid`: --inputs FILE (`path`, its time range must cover the run), else the
// model's default expressions at the sample times; empty for a model without inputs. BadFlag names
// --inputs.
InputSignal InputsFlag(const std::string& path, const ModelSpec& spec, const SampleGrid& grid);
// --x0 or the model's default; BadFlag when it has the wrong size or lies outside C and D (at the
// context `at`: t = 0 and u(0) for a model with inputs).
Vec InitialStateFlag(const TrajectoryFlags& flags, const Model& model, const Context& at = {});
// --x0-known [all | NAME,...]: which components of x0 are known (not estimated). `text` is the
// option's value ("" or "all": every component); not given: none.
// BadFlag naming --x0-known for a name that is not a state, or one named twice.
struct X0Known {
  std::string text;
  const CLI::Option* option = nullptr;  // set by AddX0KnownOption
  bool given() const { return option != nullptr && option->count() > 0; }
};
CLI::Option* AddX0KnownOption(CLI::App& cmd, X0Known& flag, const std::string& help);
std::vector<int> X0KnownFlag(const X0Known& flag, const Model& model);
// A setting of `hysid identify` registered from its description (experiments/request/settings.hpp): the
// flag's name, help and shown default come from the table; the overload (by the target's type) must
// match the setting's type (an internal error otherwise).
CLI::Option* AddSetting(CLI::App& cmd, std::string_view name, bool& target);                      // kSwitch
CLI::Option* AddSetting(CLI::App& cmd, std::string_view name, double& target);                    // kNumber
CLI::Option* AddSetting(CLI::App& cmd, std::string_view name, std::vector<double>& target);       // kNumbers
CLI::Option* AddSetting(CLI::App& cmd, std::string_view name, std::string& target);               // kText
CLI::Option* AddSetting(CLI::App& cmd, std::string_view name, std::vector<std::string>& target);  // kTexts
CLI::Option* AddSetting(CLI::App& cmd, std::string_view name, X0Known& target);                   // kStateNames
// --mode NAME: the index of a hybrid automaton's initial mode (the model's default_mode when empty);
// refused (exit 2) for a model without modes and for a name that is not one of them.
int ModeFlag(const std::string& name, const Model& model);
// "x0 known", "x0 unknown", or "x0[v] known": for the run's header line.
std::string X0KnownText(const std::vector<int>& known, const Model& model);
// "mean e_alpha A, mean e_beta B, mean e_gamma G": the bound's CRLB-implied mean errors of the blocks
// of θ with unknown entries only ("" when none), each to `digits` significant digits.
std::string CrlbMeanErrors(const Unknowns& unknowns, const Crlb& bound, int digits);

// hysid identify's refinement flags (--refine, --json, --x0-known, --x0), read into the request.
struct RefineArgs {
  std::string refine = "ml";
  std::string json;
  X0Known x0_known;          // --x0-known: components of x0 held at --x0 (one chain only)
  TrajectoryFlags x0;        // --x0 (the known values; default: the model's)
};
void AddRefineOptions(CLI::App* cmd, RefineArgs& args);
// After RunRecursivePass and the recursive report: the refinement (RunRefinement), the estimates with
// standard errors (and CRLB ratios when the data carry the truth), the trace's fitted columns (`trace`),
// --json (with `selection` added when not null). Returns the exit code: 1 when the refinement ran and
// its status is not ok. `refined`: the outcome's refinement has run already (a selection's
// DropUnsupportedTerms), only its report is made.
int RefineAndReport(const IdentifyRequest& request, IdentifyOutcome& outcome, const RefineArgs& args,
                    const std::string& trace, const nlohmann::json& selection, bool refined = false);
// The truth of data written by `hysid simulate`: x0 and σ from its sidecar FILE.json; empty when
// there is none.
Truth ReadTruth(const std::string& data_path, int n);

// The sample grid of --t-end and --dt (or the model's defaults); BadFlag when either is not a finite
// positive number or the grid exceeds the samples limit (core/io/limits.hpp).
SampleGrid GridFlag(const TrajectoryFlags& flags, const Model& model);

// A CLI11 transformer for unsigned 64-bit options (use with ->transform): decimal digits only (CLI11
// would wrap -1 to 2^64 − 1, read 010 as octal 8 and 0x10 as hex), at most 2^64 − 1 (CLI11 would
// saturate), leading zeros dropped so that CLI11 reads the rest as decimal.
inline const CLI::Validator NonNegativeInteger(
    [](std::string& text) { return NonNegativeIntegerProblem(text); },
    "NONNEGATIVE", "non-negative integer");

// Comma-separated lists: each value of the flag (it may be repeated) split at commas; an empty item
// is refused, as is an item of AddNumberList that is not a number; AddTextList's items lose their
// leading and trailing spaces and tabs. Each parse replaces `values`.
// `text` without its leading and trailing spaces and tabs.
std::string Trimmed(const std::string& text);
CLI::Option* AddTextList(CLI::App& cmd, const std::string& flag, std::vector<std::string>& values,
                         const std::string& help);
CLI::Option* AddNumberList(CLI::App& cmd, const std::string& flag, std::vector<double>& values,
                           const std::string& help);

// Checks that every entry is finite; `flag` names the option in the error.
void RequireFinite(const std::string& flag, const std::vector<double>& values);

// "rls (recursive least squares); gtls (...); …" from the descriptors, for a flag's help.
template <class Descriptor>
std::string PluginHelp(const char* what, const std::vector<Descriptor>& descriptors) {
  std::vector<std::string> parts;
  for (const Descriptor& d : descriptors) parts.push_back(fmt::format("{} ({})", d.name, d.help));
  return fmt::format("{}: {}", what, fmt::join(parts, "; "));
}

// --estimator and --detector by name into both estimators' and the detector's kind; errors name the flag.
void SetPluginKinds(const std::string& estimator, const std::string& detector, IdentifierSettings* settings);

// Adds --sigma (comma-separated) with the given help; read it with CheckedSigma or CheckedNoiseSigma.
CLI::Option* AddSigmaOption(CLI::App& cmd, std::vector<double>& sigma, const std::string& help);
// Adds --rtol and --atol, the integrator's tolerances; `covers` ends their help (may be empty).
void AddToleranceOptions(CLI::App& cmd, SimOptions& sim, const std::string& covers);

}  // namespace hysid::cli
