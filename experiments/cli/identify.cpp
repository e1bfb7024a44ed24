// hysid identify: the paper's identifier on measured samples from a CSV.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <tuple>
#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "core/identify/identifier.hpp"
#include "core/identify/metrics.hpp"
#include "core/io/csv.hpp"
#include "core/io/files.hpp"
#include "core/io/limits.hpp"
#include "core/io/sample_data.hpp"
#include "core/model/automaton.hpp"
#include "core/sets/set_metrics.hpp"
#include "experiments/request/checks.hpp"
#include "experiments/cli/cli.hpp"
#include "experiments/cli/identify_events.hpp"
#include "experiments/cli/identify_output.hpp"
#include "experiments/request/outcome_json.hpp"
#include "experiments/request/request.hpp"
#include "experiments/cli/select.hpp"

namespace hysid::cli {
namespace {

struct IdentifyArgs {
  ModelFlags model;
  std::vector<std::string> bounds;   // --param-bound NAME=LO,HI, repeatable
  std::vector<std::string> data;     // --data, repeatable: one run per file (or a run column)
  std::vector<std::string> columns;  // --columns t=NAME,STATE,...[,run=NAME]
  double max_gap = 0.0;              // --max-gap (0: 5 × the median step)
  std::string estimator = "rls";
  std::string detector = "residual";
  // Plugin options given on the command line, by keyword ("r", "jump_forgetting"): the text to parse.
  std::map<std::string, std::string> options;
  std::vector<double> flow_shape, jump_shape;  // user noise shapes C, row-major
  bool localize = false;
  bool second_pass = false;
  bool keep_outliers = false;
  std::vector<double> sigma;
  double data_rtol = 0.0, data_atol = 0.0;
  bool data_accuracy_given = false;  // --data-rtol or --data-atol on the command line
  std::string trace;
  std::string hulls;
  std::string progress = "auto";  // --progress
  RefineArgs refine;  // --refine, --json, --x0-known, --x0 (identify_refine.cpp)
  SelectArgs select;  // --chosen-model, --select-* (select.cpp)
};



// The sidecar FILE.json that `hysid simulate` writes beside FILE.csv, or null when there is none (or
// it is not a sidecar of `simulate`). A sidecar that exists must be a readable regular file.
nlohmann::json ReadSidecar(const std::filesystem::path& data) {
  const std::filesystem::path sidecar = std::filesystem::path(data).replace_extension(".json");
  if (std::error_code ec; !std::filesystem::exists(sidecar, ec)) return nullptr;
  nlohmann::json meta =
      nlohmann::json::parse(ReadWholeFile(sidecar, "sidecar"), nullptr, /*allow_exceptions=*/false);
  if (!meta.is_object() || !meta.contains("command") || meta["command"] != "simulate") return nullptr;
  return meta;
}

// Data written by `hysid simulate` has a sidecar FILE.json with the solver's tolerances: without
// --data-rtol/--data-atol they are the data's accuracy (noise-free data is then as exact as that).
// Returns where the accuracy came from.
std::string ReadSidecarAccuracy(const IdentifyArgs& args, IdentifyRequest* request) {
  if (args.data_accuracy_given) return "as given";
  const nlohmann::json meta = ReadSidecar(args.data.front());
  if (meta.is_null() || !meta.contains("solver") || !meta["solver"].is_object() ||
      !meta["solver"].contains("rtol") || !meta["solver"].contains("atol")) {
    return "none given";
  }
  const std::string sidecar = std::filesystem::path(args.data.front()).replace_extension(".json").string();
  for (const char* key : {"rtol", "atol"}) {
    const nlohmann::json& v = meta["solver"][key];
    if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() < 0.0) {
      throw std::invalid_argument(
          fmt::format("{}: solver.{} = {}: must be a number >= 0 (the tolerance the data "
                      "were simulated with)",
                      sidecar, key, Abbreviated(v.dump(), 40)));
    }
  }
  request->data_rtol = meta["solver"]["rtol"].get<double>();
  request->data_atol = meta["solver"]["atol"].get<double>();
  return fmt::format("the solver tolerances in {}", sidecar);
}

// One parameter of a sidecar's "parameters" set on `model` as the truth; `given` holds the names
// --param set, `taken` the values earlier sidecars gave (name -> value, sidecar).
void TakeTrueParameter(const std::string& sidecar, const std::string& name, const nlohmann::json& value,
                       const std::map<std::string, std::string>& given,
                       std::map<std::string, std::pair<double, std::string>>& taken, Model* model) {
  const ModelSpec& spec = model->spec();
  const std::string key = fmt::format("{}: parameters.{}", sidecar, Abbreviated(name, 40));
  if (!value.is_number()) throw std::invalid_argument(fmt::format("{}: not a number", key));
  const double v = value.get<double>();
  std::optional<std::pair<const Parameter*, double>> found;
  for (std::size_t i = 0; i < spec.alpha.size(); ++i)
    if (spec.alpha[i].name == name) found.emplace(&spec.alpha[i], model->alpha()[Eigen::Index(i)]);
  for (std::size_t i = 0; i < spec.beta.size(); ++i)
    if (spec.beta[i].name == name) found.emplace(&spec.beta[i], model->beta()[Eigen::Index(i)]);
  for (std::size_t i = 0; i < spec.guard_params.size(); ++i)
    if (spec.guard_params[i].name == name) found.emplace(&spec.guard_params[i], model->gamma()[Eigen::Index(i)]);
  if (!found) {
    throw std::invalid_argument(fmt::format(
        "{}: model '{}' has no such parameter: the data were simulated with another model", key, spec.name));
  }
  const auto [parameter, current] = *found;
  if (parameter->known && v != current) {
    throw std::invalid_argument(
        fmt::format("{} = {:.17g}: a known constant of model '{}', which is {:.17g} here: "
                    "the data were simulated with another model",
                    key, v, spec.name, current));
  }
  if (const auto at = given.find(name); at != given.end() && v != current) {
    throw std::invalid_argument(fmt::format(
        "--param {}: the sidecar {} gives {} = {:.17g}, the value the data were simulated with (the "
        "truth); give that value or leave --param out",
        Abbreviated(at->second), sidecar, Abbreviated(name, 40), v));
  }
  if (const auto [at, fresh] = taken.emplace(name, std::pair{v, sidecar}); !fresh && at->second.first != v) {
    throw std::invalid_argument(
        fmt::format("{} = {:.17g}, but {} gives {:.17g}: the --data files were simulated "
                    "with different parameters",
                    key, v, at->second.second, at->second.first));
  }
  if (!parameter->known) model->SetParameter(name, v);
}

// The truth the metrics and the CRLB compare with: for data written by `hysid simulate`, the α, β and γ
// in the sidecars of the --data files (of the same model name), set on `model`; else the model's
// values (defaults and --param). A --param that disagrees with a sidecar, sidecars that disagree, and
// a sidecar parameter the model lacks or holds as another constant are refused. Returns the source.
std::string TakeSidecarTruth(const IdentifyArgs& args, Model* model) {
  std::map<std::string, std::string> given;  // --param name -> its assignment
  for (const std::string& p : args.model.params) given.emplace(p.substr(0, p.find('=')), p);
  std::map<std::string, std::pair<double, std::string>> taken;
  std::vector<std::string> used, other;
  for (const std::string& d : args.data) {
    const nlohmann::json meta = ReadSidecar(d);
    const std::string sidecar = std::filesystem::path(d).replace_extension(".json").string();
    if (meta.is_null() || !meta.contains("parameters")) continue;
    if (!meta.contains("model") || meta["model"] != model->name()) {
      other.push_back(
          fmt::format("{} is of model {}", sidecar, meta.value("model", nlohmann::json()).dump()));
      continue;
    }
    if (!meta["parameters"].is_object())
      throw std::invalid_argument(fmt::format("{}: parameters: not an object", sidecar));
    for (const auto& [name, value] : meta["parameters"].items())
      TakeTrueParameter(sidecar, name, value, given, taken, model);
    used.push_back(sidecar);
  }
  std::string source = !used.empty()    ? fmt::format("the parameters in {}", fmt::join(used, ", "))
                       : !given.empty() ? "the model's values with --param"
                                        : "the model's default values";
  if (!other.empty()) source += fmt::format(" ({})", fmt::join(other, "; "));
  return source;
}

// "r = 220, tau0 = 100000, bound = auto": the options the detector reads.
std::string DetectorOptionText(const DetectorSettings& s) {
  std::vector<std::string> parts;
  for (const auto& o : DetectorOptions()) {
    if (DescriptorOf(s.kind).Reads(o.name))
      parts.push_back(fmt::format("{} = {}", o.name, o.Format(o.get(s))));
  }
  return fmt::format("{}", fmt::join(parts, ", "));
}

void PrintSettings(const IdentifyArgs& args, const ModelSpec& spec, const SampleData& data,
                   const IdentifierSettings& settings, const std::string& accuracy_source,
                   const IdentifyResult& result) {
  std::printf("model %s, data %s (%s), %zu samples, dt = %.6g%s\n", spec.name.c_str(), data.path.c_str(),
              fmt::format("{}", fmt::join(data.state_columns, ",")).c_str(), data.t.size(), data.dt,
              data.uniform ? "" : " (median step)");
  if (!data.uniform) {
    std::printf(
        "runs: %zu, chains: %ld (gaps longer than %.6g s: %ld; rows with a missing value: %ld%s); "
        "each sample pair uses its own step\n",
        data.run_names.size(), data.chains(), data.max_gap, data.gaps, data.missing_rows,
        data.missing_rows ? fmt::format(", the first on line {}", data.first_missing_line).c_str() : "");
  }
  for (const OutlierSample& o : data.outliers) {
    std::printf(
        "outlier left out: %s line %ld, t = %.6g: %s = %.6g, its second difference %.3g robust sd off "
        "both neighbours (--keep-outliers keeps it)\n",
        data.run_names[std::size_t(o.run)].c_str(), o.line, o.t,
        data.state_columns[std::size_t(o.row)].c_str(), o.value, o.sds);
  }
  const std::string beta = settings.jump_estimator.kind == settings.flow_estimator.kind
                               ? ""
                               : fmt::format(" (beta: {})", ToString(settings.jump_estimator.kind));
  std::printf("estimator %s%s, detector %s (%s; data accuracy rtol %g, atol %g: %s)", args.estimator.c_str(),
              beta.c_str(), args.detector.c_str(), DetectorOptionText(settings.detector).c_str(),
              settings.data_rtol, settings.data_atol, accuracy_source.c_str());
  std::printf("%s%s\n", args.localize ? ", localised jumps" : "", args.second_pass ? ", second pass" : "");
  if (result.noise_sigma.size()) {
    std::printf("noise shapes C from sigma = (%s)%s, dt = %.6g (flow C diagonal: %s; jump C diagonal: %s)\n",
                fmt::format("{:.4g}", fmt::join(result.noise_sigma, ", ")).c_str(),
                result.noise_sigma_estimated ? ", estimated from the data (MAD of 2nd differences)"
                                             : " as given by --sigma",
                data.dt,
                args.flow_shape.empty()
                    ? fmt::format("{:.4g}", fmt::join(result.flow_noise_shape.diagonal(), ", ")).c_str()
                    : "given",
                args.jump_shape.empty()
                    ? fmt::format("{:.4g}", fmt::join(result.jump_noise_shape.diagonal(), ", ")).c_str()
                    : "given");
  } else if (result.flow_noise_shape.size() || result.jump_noise_shape.size()) {
    std::printf("noise shapes C as given by --flow-noise-shape / --jump-noise-shape\n");
  }
}

// Which states are measured and which reconstructed (nothing when all are measured).
void PrintPartial(const Model& model, const PartialOutputs& partial) {
  if (partial.reconstructed.empty()) return;
  auto named = [&](const std::vector<int>& indices) {
    std::vector<std::string> out;
    for (const int i : indices) out.push_back(model.spec().state_names[static_cast<std::size_t>(i)]);
    return fmt::format("{}", fmt::join(out, ", "));
  };
  std::printf("measured states: %s; reconstructed: %s\n", named(partial.measured).c_str(),
              partial.reconstruction.c_str());
}

void PrintEstimates(const ModelSpec& spec, const IdentifyArgs& args, const IdentifyResult& result) {
  for (std::size_t i = 0; i < spec.alpha.size(); ++i) {
    if (!spec.alpha[i].known) {
      std::printf("  alpha %-10s = %.10g\n", spec.alpha[i].name.c_str(), result.alpha_hat[Eigen::Index(i)]);
    }
  }
  for (std::size_t i = 0; i < spec.beta.size(); ++i) {
    if (!spec.beta[i].known) {
      std::printf("  beta  %-10s = %.10g\n", spec.beta[i].name.c_str(), result.beta_hat[Eigen::Index(i)]);
    }
  }
  std::printf("jumps detected: %ld (flow estimator %s, jump estimator %s)\n", result.jumps_detected,
              ToString(result.flow_status), ToString(result.jump_status));
  for (const auto& [status, reason, what] : {std::tuple{result.flow_status, &result.flow_reason, "flow"},
                                             std::tuple{result.jump_status, &result.jump_reason, "jump"}}) {
    if (status != EstimatorStatus::kOk && !reason->empty())
      std::printf("  %s estimator: %s\n", what, reason->c_str());
  }
  // Estimators that report one (frisch): the solution boxes of the unknowns, in the order printed above.
  for (const auto& [box, what] :
       {std::pair{&result.flow_box, "alpha"}, std::pair{&result.jump_box, "beta"}}) {
    if (box->size() == 0) continue;
    std::printf("%s box %s:", args.estimator.c_str(), what);
    for (Eigen::Index i = 0; i < box->rows(); ++i) std::printf(" [%.6g, %.6g]", (*box)(i, 0), (*box)(i, 1));
    std::printf("\n");
  }
  if (args.localize) {
    std::printf("jumps localised: %ld of %ld\n", result.jumps_localized, result.jumps_detected);
  }
  if (result.second_pass) {
    std::printf(
        "second pass: %ld samples flow -> jump, %ld jump -> flow (first pass: %ld jumps)\n",
        result.reclassified_to_jump, result.reclassified_to_flow,
        static_cast<long>(std::count(result.first_pass_gamma.begin(), result.first_pass_gamma.end(), 1)));
  }
}

// Against the data's column j and the model's true values and sets.
void PrintTruth(const Model& model, const std::vector<int>& j, const std::string& truth_source,
                const IdentifyResult& result) {
  const Confusion c = CompareJumps(j, result.gamma);
  const ParameterErrors e = CompareParameters(model, result.alpha_hat, result.beta_hat);
  std::printf("truth (column j): %ld true jumps; TP %ld, FP %ld, FN %ld, TN %ld\n", c.tp + c.fn, c.tp, c.fp,
              c.fn, c.tn);
  std::printf("  misclassification %.6g, precision %.6g, recall %.6g\n", c.misclassification(), c.precision(),
              c.recall());
  std::printf("  e_alpha %.6g, e_beta %.6g (relative %.6g, %.6g) against %s\n", e.e_alpha, e.e_beta,
              e.rel_alpha, e.rel_beta, truth_source.c_str());
  // Ĉ and D̂ against the model's C and D (when computed: not beyond the hull dimension limit).
  if (!result.sets_skipped.empty()) {
    std::printf("  sets: not computed\n");
    return;
  }
  if (model.input_size() > 0) {  // C and D may move with u, which a hull vertex does not keep
    std::printf("  sets: C^ has %ld vertices, D^ %ld (not compared: C and D of a model with inputs)\n",
                static_cast<long>(result.flow_hull.cols()), static_cast<long>(result.jump_hull.cols()));
    return;
  }
  const SetMetrics sm = CompareSets(model, result.flow_hull, result.jump_hull);
  std::printf("  sets: C^ has %ld vertices (%s %.6g), %.6g of it outside C; D^ has %ld vertices, ",
              static_cast<long>(result.flow_hull.cols()), model.state_size() >= 3 ? "volume" : "area",
              result.flow_hull_volume, sm.flow_outside_share, static_cast<long>(result.jump_hull.cols()));
  if (model.has_jump_set_distance()) {
    std::printf("within %.6g of D (one-sided Hausdorff)\n", sm.jump_hausdorff);
  } else {
    std::printf("distance to D unknown (the model has no DistanceToJumpSet)\n");
  }
}

// A --columns entry without the spaces around its '=' ("t = time" is "t=time"; the items themselves
// are trimmed by AddTextList).
std::string ColumnEntry(const std::string& entry) {
  const std::size_t eq = entry.find('=');
  if (eq == std::string::npos) return entry;
  return Trimmed(entry.substr(0, eq)) + "=" + Trimmed(entry.substr(eq + 1));
}

// The data files (the columns of the measured states); a message about the column choice names the flag.
SampleData ReadData(const IdentifyArgs& args, const Model& model) {
  std::vector<std::string> columns;
  for (const std::string& entry : args.columns) columns.push_back(ColumnEntry(entry));
  return ReadSampleFiles(args.data, model, columns, args.max_gap, Spelling::kFlag);
}

// --trace, --hulls and --json: each writable, no two the same file, none an input of this run (a
// --data file, its sidecar FILE.json, the model file). FILE.json is an input only when it is a
// sidecar of `simulate` (ReadSidecar): an earlier --json report of FILE.csv there is an output, replaced.
void CheckOutputs(const IdentifyArgs& args) {
  InputFiles inputs;
  for (const std::string& d : args.data) {
    inputs.Add("--data", d);
    if (!ReadSidecar(d).is_null())
      inputs.Add("--data (sidecar)", std::filesystem::path(d).replace_extension(".json"));
  }
  inputs.Add("--model-file", args.model.file);
  std::vector<std::pair<std::string, std::filesystem::path>> outputs;
  for (const auto& [flag, path] : {std::pair{"--trace", &args.trace}, std::pair{"--hulls", &args.hulls},
                                   std::pair{"--json", &args.refine.json},
                                   std::pair{"--chosen-model", &args.select.chosen_model}}) {
    if (!path->empty()) outputs.emplace_back(flag, *path);
  }
  CheckOutputPaths(outputs, inputs);
}

// The request from the flags (the model's bounds and truth already set); errors name the flag.
IdentifyRequest MakeRequest(const IdentifyArgs& args, const Model& model) {
  IdentifyRequest r(model);
  r.estimator = args.estimator;
  r.detector = args.detector;
  r.plugin_options = args.options;
  r.flow_noise_shape = NoiseShapeOf(args.flow_shape, "flow_noise_shape", Spelling::kFlag);
  r.jump_noise_shape = NoiseShapeOf(args.jump_shape, "jump_noise_shape", Spelling::kFlag);
  r.localize = args.localize;
  r.second_pass = args.second_pass;
  r.keep_outliers = args.keep_outliers;
  r.trace = !args.trace.empty();
  r.statistics = r.trace;  // the detector's statistic and threshold: only the trace shows them
  r.sigma = args.sigma;
  r.data_rtol = args.data_rtol;
  r.data_atol = args.data_atol;
  r.refine = args.refine.refine;
  const X0Known& x0_known = args.refine.x0_known;
  r.x0_known = x0_known.given() ? std::optional<std::string>(x0_known.text) : std::nullopt;
  r.x0 = args.refine.x0.x0;
  r.release_per_sample = true;
  r.spelling = Spelling::kFlag;
  return r;
}

// A model file with candidate terms: choose the terms on the pass with every candidate, identify the
// chosen model, choose again on its detections until the support holds (at most kSelectRounds
// passes); the outcome goes on with the chosen model.
SelectStep SelectTerms(const IdentifyArgs& args, const IdentifyRequest& request, IdentifyOutcome* outcome) {
  constexpr int kSelectRounds = 3;
  const Model full = outcome->model;
  SelectStep select = SelectCandidates(full, args.model.file, outcome->data, outcome->recursive, args.select, false);
  for (int round = 2;; ++round) {
    RunRecursivePassAgain(request, *select.chosen, outcome);
    if (round > kSelectRounds) break;
    SelectStep again = SelectCandidates(full, args.model.file, outcome->data, outcome->recursive, args.select, true);
    again.round = round;
    const bool held = again.kept == select.kept;
    select = std::move(again);
    if (held) break;
  }
  PrintSelection(select);
  return select;
}

// The recursive run's text report (with the note on start values whose guards the default
// trajectory does not reach), --trace and --hulls.
void ReportRecursive(const IdentifyArgs& args, const IdentifyRequest& request, const IdentifyOutcome& o,
                     const std::string& truth_source, const std::string& start_note) {
  const Model& model = o.model;
  const IdentifyResult& result = o.recursive;
  PrintSettings(args, model.spec(), o.data, o.settings, request.data_accuracy_source, result);
  if (!start_note.empty()) std::printf("note: %s\n", start_note.c_str());
  PrintPartial(model, o.partial);
  PrintEstimates(model.spec(), args, result);
  PrintEvents(model, o.data, result);
  if (!result.sets_skipped.empty())
    std::printf("sets C^ and D^: not computed: %s\n", result.sets_skipped.c_str());
  if (o.data.j) PrintTruth(model, *o.data.j, truth_source, result);
  if (!args.trace.empty()) {
    WriteTrace(args.trace, model.spec(), DescriptorOf(o.settings.detector.kind), o.data, result);
  }
  if (!args.hulls.empty()) WriteHulls(args.hulls, model.spec(), result);
}

int RunIdentify(const IdentifyArgs& args, const Environment& env) {
  std::string start_note;  // a guard the start values' default trajectory does not reach
  Model model = MakeModel(env, args.model, ModelValues::kStart, &start_note);
  CheckBoundsNeedRefinement(!args.bounds.empty(), args.refine.refine, Spelling::kFlag);
  ApplyBoundFlags(args.bounds, &model);  // on the model as given, before the sidecar's truth
  std::string truth_source = TakeSidecarTruth(args, &model);
  IdentifyRequest request = MakeRequest(args, model);
  CheckRequest(request);  // settings errors before the data is read
  CheckSelectArgs(args.select, model);
  request.data = ReadData(args, model);
  CheckRequestData(request);
  request.data_accuracy_source = ReadSidecarAccuracy(args, &request);
  if (request.data.j && request.data.uniform) request.truth = ReadTruth(request.data.path, model.state_size());
  CheckOutputs(args);
  StageProgress progress("identify", ProgressFlag(args.progress));
  request.progress = &progress;
  progress.Stage("recursive pass");
  IdentifyOutcome outcome = RunRecursivePass(request);
  progress.Clear();
  std::optional<SelectStep> select;
  if (!model.spec().candidates.empty() || !model.spec().jump_candidates.empty()) {
    select = SelectTerms(args, request, &outcome);
    truth_source = "the selection's least-squares values (the chosen model has no truth)";
    if (args.refine.refine == "ml") {
      DropUnsupportedTerms(request, &outcome, &*select);
      PrintFitDrops(*select);
    }
  }
  ReportRecursive(args, request, outcome, truth_source, start_note);
  const int code = RefineAndReport(request, outcome, args.refine, args.trace,
                                   select ? SelectionJson(*select) : nlohmann::json(),
                                   /*refined=*/select && args.refine.refine == "ml");
  if (select) {
    FinishSelection(*select, outcome.model, outcome.recursive,
                    args.refine.refine == "ml" ? &outcome.refinement.result : nullptr, args.select);
  }
  if (code == 0 && !outcome.ok()) {
    throw RunFailed(fmt::format("identify: the fit is not ok (flow estimator {}, jump estimator {})",
                                ToString(outcome.recursive.flow_status), ToString(outcome.recursive.jump_status)));
  }
  return code;
}

}  // namespace

void AddIdentifyCommand(CLI::App& app, Environment& env) {
  auto args = std::make_shared<IdentifyArgs>();
  CLI::App* cmd = app.add_subcommand("identify", "identify alpha, beta, C and D from measured samples");
  AddModelFlags(*cmd, args->model, "NAME=VALUE: the model's true value (for error metrics)");
  AddSetting(*cmd, "param_bound", args->bounds);
  cmd->add_option("--data", args->data,
                  "CSV (RFC 4180): time, then the measured state (the columns named after the model's "
                  "states, else y1..yn, else the first other columns); a column j is taken as ground "
                  "truth, a column run splits the file into runs; repeat --data for several runs of one "
                  "system (alpha, beta shared). Empty, nan or NA state cells: the row is left out (the "
                  "chain goes on across it)")
      ->required();
  AddTextList(*cmd, "--columns", args->columns,
              "columns by header name: t=NAME (time), the state columns in model order, "
              "optionally run=NAME (run column), e.g. t=time,pos,vel");
  AddSetting(*cmd, "max_gap", args->max_gap)->each([](const std::string& text) {
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    CheckMaxGap(end == text.c_str() || *end != '\0' ? std::nan("") : v, Abbreviated(text, 40),
                Spelling::kFlag);
  });
  AddSetting(*cmd, "estimator", args->estimator);
  AddSetting(*cmd, "detector", args->detector);
  std::vector<std::pair<std::string, CLI::Option*>> option_flags;
  for (const PluginOptionArgument& a : PluginOptionArguments()) {
    const std::string keyword = Spelled(a.name, Spelling::kKeyword, a.prefix);
    option_flags.emplace_back(keyword, cmd->add_option(Spelled(a.name, Spelling::kFlag, a.prefix),
                                                       args->options[keyword], a.help)
                                           ->default_str(a.default_text));
  }
  AddSetting(*cmd, "flow_noise_shape", args->flow_shape);
  AddSetting(*cmd, "jump_noise_shape", args->jump_shape);
  AddSetting(*cmd, "localize", args->localize);
  AddSetting(*cmd, "second_pass", args->second_pass);
  AddSetting(*cmd, "keep_outliers", args->keep_outliers);
  AddSetting(*cmd, "sigma", args->sigma);
  CLI::Option* rtol_option = AddSetting(*cmd, "data_rtol", args->data_rtol);
  CLI::Option* atol_option = AddSetting(*cmd, "data_atol", args->data_atol);
  cmd->add_option("--trace", args->trace,
                  "CSV, one row per data row: run, chain, line, t, missing, the detector's statistic and "
                  "threshold, gamma, estimates; after the refinement the fitted model's run over the record, "
                  "its band, residuals and the recursive estimate's run (docs/outputs.md)");
  cmd->add_option("--hulls", args->hulls, "CSV of the hull vertices of C^ and D^");
  cmd->add_option("--progress", args->progress,
                  "auto (a line on stderr when it is a terminal and the work takes over 1 s: stage, fit, "
                  "iteration, cost), bar, lines (one every 10 s), none")
      ->capture_default_str();
  cmd->callback([args, &env, rtol_option, atol_option, option_flags] {
    args->data_accuracy_given = rtol_option->count() > 0 || atol_option->count() > 0;
    for (const auto& [keyword, option] : option_flags) {
      if (option->count() == 0) args->options.erase(keyword);
    }
    if (const int code = RunIdentify(*args, env); code != 0) throw CLI::RuntimeError(code);
  });
  AddRefineOptions(cmd, args->refine);
  AddSelectOptions(*cmd, args->select);
}

}  // namespace hysid::cli
