// The checks of user-given values shared by the command line and the Python module, so that both
// refuse the same values with the same messages. An argument is named as the caller spells it: a
// flag ("--t-end", "--jump-forgetting") on the command line, a keyword ("t_end", "jump_forgetting")
// in Python. Every check throws std::invalid_argument naming the argument and the violated constraint.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/identify/identifier.hpp"
#include "core/model/context.hpp"
#include "core/model/model.hpp"
#include "core/model/option.hpp"
#include "sim/input_signal.hpp"
#include "sim/simulator.hpp"

namespace hysid {

enum class Spelling { kFlag, kKeyword };

// "t_end" as "--t-end" (kFlag) or "t_end" (kKeyword); `prefix` ("jump") joins in front.
std::string Spelled(std::string_view name, Spelling spelling, std::string_view prefix = {});

// Every value finite: "NAME = V: must be finite".
void CheckFinite(const std::string& name, const std::vector<double>& values);

// The sample grid of t_end and dt: each finite and > 0, and within the samples limit (kMaxSamples).
SampleGrid CheckedGrid(double t_end, double dt, Spelling spelling);

// σ: one value for every state or one per state, each finite and >= 0 (> 0 without allow_zero); with
// `measured` (the indices of the states the data measure, when not all) also one per measured state,
// the others then 0.
Vec CheckedSigma(const std::vector<double>& values, int states, bool allow_zero, Spelling spelling,
                 const std::vector<int>& measured = {});

// The range in which σ (for the CRLB and a known σ of the refinement) keeps 1/σ² and the residuals
// r/σ finite and normal: "--sigma = 1e-300: out of range (1e-150 <= sigma <= 1e+150 ...)".
inline constexpr double kMinSigma = 1e-150, kMaxSigma = 1e150;
void CheckSigmaRange(const Vec& sigma, Spelling spelling);
// The noise σ of a fit or a bound, one value or one per measured state: CheckedSigma (> 0), then
// CheckSigmaRange.
Vec CheckedNoiseSigma(const std::vector<double>& values, int measured, Spelling spelling);

// The CRLB's grid: at least two samples ("--t-end = 1e-300: out of range: ... t_end >= dt").
void CheckBoundGrid(const SampleGrid& grid, Spelling spelling);

// The solver's rtol and atol (each finite and > 0) and max_jumps (>= 1): "--rtol = -1: must be > 0".
void CheckSimOptions(const SimOptions& options, Spelling spelling);

// A count (seed, trial) given as decimal text: "" when it is an integer in [0, 2^64 − 1] (`text` then
// loses its leading zeros), else the violated constraint: "must be ≥ 0, got -1".
std::string NonNegativeIntegerProblem(std::string& text);

// The refusal of a model named neither by a registered name nor by an existing file's path:
// "'NAME' is neither a registered model (a, b) nor a model file".
std::string NeitherModelNorFile(const std::string& name, const std::vector<std::string>& registered);

// The refinement's choices ("ml", "none"): "" or "maybe not in {ml,none}" (CLI11's wording, as the
// command line's --refine checks it).
std::string RefineChoiceProblem(const std::string& value);

// A noise shape given (flow_given, jump_given) for an estimator that uses none: "--flow-noise-shape:
// the alpha estimator rls uses no noise shape (only gtls, frisch do)". The kinds must be set.
void CheckNoiseShapesUsed(const IdentifierSettings& settings, bool flow_given, bool jump_given,
                          Spelling spelling);

// Parameter bounds given while the refinement, the only part that honours bounds, is off: "--param-bound:
// bounds act on the refinement; with --refine none ...".
void CheckBoundsNeedRefinement(bool bounds_given, const std::string& refine, Spelling spelling);

// max_gap, the longest step inside a chain: a number > 0 (seconds); `shown` is the value as the user gave
// it: "--max-gap = 0: must be a number > 0 (seconds)".
void CheckMaxGap(double value, std::string_view shown, Spelling spelling);

// data_rtol and data_atol: finite and >= 0.
void CheckDataAccuracy(double data_rtol, double data_atol, Spelling spelling);

// The estimator (of α and β) and the detector by name; errors name the argument.
void SetPluginKinds(const std::string& estimator, const std::string& detector, Spelling spelling,
                    IdentifierSettings* settings);

// One plugin option as an argument: detector options, the α estimator's, the β estimator's
// ("jump" prefix).
struct PluginOptionArgument {
  std::string name;    // the option's name ("forgetting")
  std::string prefix;  // "" or "jump"
  std::string help;    // "rls, gtls: forgetting factor (alpha estimator)"
  std::string default_text;
  OptionType type = OptionType::kReal;
  std::vector<std::string> choices;  // kChoice: the names allowed
  std::vector<std::string> read_by;  // the plugins that read it ("rls", "gtls")
  // Parses the text into `settings` (throws std::invalid_argument naming the option).
  std::function<void(IdentifierSettings&, std::string_view)> set;
  // "" when the plugin chosen in `settings` reads the option, else why not: "the detector 'residual'
  // does not read it (its options: --false-alarm, --bound)".
  std::function<std::string(const IdentifierSettings&, Spelling)> unread;
};
const std::vector<PluginOptionArgument>& PluginOptionArguments();

// The given options (by keyword: "r", "jump_forgetting"; as text) into `settings`, whose kinds are
// already set: an unknown name, a value the option refuses, or an option the chosen plugin does not
// read is an error naming the argument as `spelling` spells it (and the plugin).
void ApplyPluginOptions(const std::map<std::string, std::string>& given, Spelling spelling,
                        IdentifierSettings* settings);

// ---- arguments of one model's run, shared by identify, simulate and crlb ----

// Parameter bounds "NAME=LO,HI" set on the model (Model::SetBounds); errors name param_bound: malformed
// text, a name given twice or unknown, a known constant, LO >= HI, or the model's value outside [LO, HI].
void ApplyBounds(const std::vector<std::string>& bounds, Spelling spelling, Model* model);

// The known components of x0: nullopt (not given) none; "" or "all" every one; else state names,
// comma-separated. Errors name x0_known: a name that is not a state, or one named twice.
std::vector<int> KnownX0(const std::optional<std::string>& text, const Model& model, Spelling spelling);

// x0 (the model's default when empty): finite, one value per state, inside C or D at the context `at`.
Vec CheckedX0(const std::vector<double>& x0, const Model& model, const Context& at, Spelling spelling);

// The index of a hybrid automaton's initial mode by name (the model's default_mode when empty);
// refused for a model without modes and for a name that is not one of them.
int ModeIndex(const std::string& name, const Model& model, Spelling spelling);

// The inputs of a run over `grid`: the file `path` (its time range must cover the run), else the
// model's default expressions at the sample times; empty for a model without inputs. Errors name inputs.
InputSignal CheckedInputs(const std::string& path, const ModelSpec& spec, const SampleGrid& grid,
                          Spelling spelling);

// The samples of `grid` at `times` (a record with missing rows and gaps), one entry per grid sample
// (1: present). Each time must be a grid time k·dt (within 1e-6 dt), once; at least two. `where(i)`
// names time i in a message, `name` the whole.
std::vector<std::uint8_t> SamplesAtTimes(const std::vector<double>& times, const SampleGrid& grid,
                                         const std::string& name,
                                         const std::function<std::string(std::size_t)>& where);
// SamplesAtTimes of the column t of the CSV file `path`, its rows with a missing cell left out (as
// identify leaves them out); errors name the flag, the file and the line.
std::vector<std::uint8_t> CheckedSampleTimes(const std::string& path, const SampleGrid& grid,
                                             Spelling spelling);

}  // namespace hysid
