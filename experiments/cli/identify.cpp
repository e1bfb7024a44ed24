// hysid identify: the paper's identifier on measured samples from a CSV.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
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
#include "core/sets/set_metrics.hpp"
#include "experiments/cli/checks.hpp"
#include "experiments/cli/cli.hpp"

namespace hysid::cli {
namespace {

struct IdentifyArgs {
  ModelFlags model;
  std::vector<std::string> data;     // --data, repeatable: one run per file (or a run column)
  std::vector<std::string> columns;  // --columns t=NAME,STATE,...[,run=NAME]
  double max_gap = 0.0;              // --max-gap (0: 5 × the median step)
  std::string estimator = "rls";
  std::string detector = "residual";
  // Plugin options given on the command line, by flag ("--r", "--jump-forgetting"): the text to parse.
  std::map<std::string, std::string> options;
  std::vector<double> flow_shape, jump_shape;  // user noise shapes C, row-major
  bool localize = false;
  bool second_pass = false;
  std::vector<double> sigma;
  double data_rtol = 0.0, data_atol = 0.0;
  bool data_accuracy_given = false;  // --data-rtol or --data-atol on the command line
  std::string trace;
  std::string hulls;
  RefineArgs refine;  // --refine, --json (identify_refine.cpp)
};

Mat NoiseShapeFlag(const std::vector<double>& v, const char* flag) {
  if (v.empty()) return Mat();
  RequireFinite(flag, v);
  const auto m = static_cast<Eigen::Index>(std::lround(std::sqrt(double(v.size()))));
  if (m * m != static_cast<Eigen::Index>(v.size())) {
    BadFlag(
        fmt::format("{} has {} values: give a square matrix (parameters + 1)^2, row-major", flag, v.size()));
  }
  return Mat(Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      v.data(), m, m));
}

// The identifier's settings from the flags; errors name the flag.
IdentifierSettings BuildSettings(const IdentifyArgs& args, const Model& model) {
  IdentifierSettings settings;
  SetPluginKinds(args.estimator, args.detector, &settings);
  ApplyPluginOptions(args.options, Spelling::kFlag, &settings);
  settings.flow_estimator.noise_shape = NoiseShapeFlag(args.flow_shape, "--flow-noise-shape");
  settings.jump_estimator.noise_shape = NoiseShapeFlag(args.jump_shape, "--jump-noise-shape");
  settings.localize = args.localize;
  settings.second_pass = args.second_pass;
  CheckDataAccuracy(args.data_rtol, args.data_atol, Spelling::kFlag);
  settings.data_rtol = args.data_rtol;
  settings.data_atol = args.data_atol;
  if (!args.sigma.empty()) settings.sigma = SigmaFlag(args.sigma, model.state_size());
  // Settings errors (noise shape sizes, ...) before the data is read.
  try {
    Identifier check(model, 1.0, settings);
  } catch (const std::invalid_argument& e) {
    BadFlag(fmt::format("--estimator/--detector/--*-noise-shape: {}", e.what()));
  }
  return settings;
}

// Data written by `hysid simulate` has a sidecar FILE.json with the solver's tolerances: without
// --data-rtol/--data-atol they are the data's accuracy (noise-free data is then as exact as that).
// Returns where the accuracy came from.
std::string ReadSidecarAccuracy(const IdentifyArgs& args, IdentifierSettings* settings) {
  if (args.data_accuracy_given) return "as given";
  const std::filesystem::path sidecar = std::filesystem::path(args.data.front()).replace_extension(".json");
  std::ifstream in(sidecar);
  if (!in) return "none given";
  const nlohmann::json meta = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (!meta.is_object() || meta.value("command", "") != "simulate" || !meta.contains("solver") ||
      !meta["solver"].is_object() || meta["solver"].value("rtol", -1.0) < 0.0 ||
      meta["solver"].value("atol", -1.0) < 0.0) {
    return "none given";
  }
  settings->data_rtol = meta["solver"]["rtol"].get<double>();
  settings->data_atol = meta["solver"]["atol"].get<double>();
  return fmt::format("the solver tolerances in {}", sidecar.string());
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
void PrintTruth(const Model& model, const std::vector<int>& j, const IdentifyResult& result) {
  const Confusion c = CompareJumps(j, result.gamma);
  const ParameterErrors e = CompareParameters(model, result.alpha_hat, result.beta_hat);
  std::printf("truth (column j): %ld true jumps; TP %ld, FP %ld, FN %ld, TN %ld\n", c.tp + c.fn, c.tp, c.fp,
              c.fn, c.tn);
  std::printf("  misclassification %.6g, precision %.6g, recall %.6g\n", c.misclassification(), c.precision(),
              c.recall());
  std::printf("  e_alpha %.6g, e_beta %.6g (relative %.6g, %.6g) against the model's values\n", e.e_alpha,
              e.e_beta, e.rel_alpha, e.rel_beta);
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

// Per sample: t, the detector's statistic and threshold (paper: D_δt ξ and τ̂; residual: max |z| and
// q), γ, the estimates, and the truth when the data has it.
void WriteTrace(const std::string& path, const ModelSpec& spec, const DetectorDescriptor& detector,
                const SampleData& data, const IdentifyResult& result) {
  std::vector<std::string> header{"t", std::string(detector.traits.statistic),
                                  std::string(detector.traits.threshold), "gamma"};
  for (const auto& s : UnknownNames(spec.alpha)) header.push_back(s + "_hat");
  for (const auto& s : UnknownNames(spec.beta)) header.push_back(s + "_hat");
  if (data.j) header.insert(header.end(), {"j", "true_jump"});
  CsvWriter csv(path, header);
  std::vector<double> row(header.size());
  for (std::size_t k = 0; k < data.t.size(); ++k) {
    std::size_t c = 0;
    for (double v : {data.t[k], result.statistic[k], result.threshold[k], double(result.gamma[k])})
      row[c++] = v;
    for (std::size_t i = 0; i < spec.alpha.size(); ++i) {
      if (!spec.alpha[i].known) row[c++] = result.alpha_trace(Eigen::Index(i), Eigen::Index(k));
    }
    for (std::size_t i = 0; i < spec.beta.size(); ++i) {
      if (!spec.beta[i].known) row[c++] = result.beta_trace(Eigen::Index(i), Eigen::Index(k));
    }
    if (data.j) {
      row[c++] = (*data.j)[k];
      row[c++] = k > 0 && (*data.j)[k] != (*data.j)[k - 1] ? 1.0 : 0.0;
    }
    csv.Row(row);
  }
  csv.Commit();
  std::printf("wrote %s\n", path.c_str());
}

void WriteHulls(const std::string& path, int n, const IdentifyResult& result) {
  std::vector<std::string> header{"set", "vertex"};
  for (int i = 1; i <= n; ++i) header.push_back(fmt::format("x{}", i));
  CsvWriter csv(path, header);
  std::vector<double> row(header.size());
  int set = 0;
  for (const Mat* hull : {&result.flow_hull, &result.jump_hull}) {
    for (Eigen::Index v = 0; v < hull->cols(); ++v) {
      row[0] = set;
      row[1] = static_cast<double>(v);
      for (int i = 0; i < n; ++i) row[static_cast<std::size_t>(2 + i)] = (*hull)(i, v);
      csv.Row(row);
    }
    ++set;
  }
  csv.Commit();
  std::printf("wrote %s (set 0 = flow hull C^, set 1 = jump hull D^, vertices in order)\n", path.c_str());
}

// The data files; a message about the column choice names the flag.
SampleData ReadData(const IdentifyArgs& args, const Model& model) {
  try {
    return ReadSampleData(args.data, model.state_size(),
                          {.columns = args.columns, .inputs = model.spec().inputs, .max_gap = args.max_gap});
  } catch (const std::invalid_argument& e) {
    std::string message = e.what();
    const std::string field = "SampleDataOptions::columns";
    if (const auto at = message.find(field); at != std::string::npos)
      message.replace(at, field.size(), "--columns");
    throw std::invalid_argument(message);
  }
}

// --trace, --hulls and --json: each writable, no two the same file, none an input of this run (a
// --data file, its sidecar FILE.json, the model file).
void CheckOutputs(const IdentifyArgs& args) {
  InputFiles inputs;
  for (const std::string& d : args.data) {
    inputs.Add("--data", d);
    inputs.Add("--data (sidecar)", std::filesystem::path(d).replace_extension(".json"));
  }
  inputs.Add("--model-file", args.model.file);
  std::vector<std::pair<std::string, std::filesystem::path>> outputs;
  for (const auto& [flag, path] : {std::pair{"--trace", &args.trace}, std::pair{"--hulls", &args.hulls},
                                   std::pair{"--json", &args.refine.json}}) {
    if (!path->empty()) outputs.emplace_back(flag, *path);
  }
  CheckOutputPaths(outputs, inputs);
}

int RunIdentify(const IdentifyArgs& args, const Environment& env) {
  const Model model = MakeModel(env, args.model);
  IdentifierSettings settings = BuildSettings(args, model);
  const SampleData data = ReadData(args, model);
  const std::string accuracy_source = ReadSidecarAccuracy(args, &settings);
  IdentifyOptions options;
  options.trace = !args.trace.empty();
  CheckOutputs(args);
  if (!data.uniform) {  // each pair with its own step, chains restarted at runs, gaps and missing rows
    options.times = data.t;
    options.chain_start = data.chain_start;
  }
  options.inputs = data.u;  // m × K: the model's inputs, read by name
  const IdentifyResult result = Identify(model, data.y, data.dt, settings, options);
  PrintSettings(args, model.spec(), data, settings, accuracy_source, result);
  PrintEstimates(model.spec(), args, result);
  if (!result.sets_skipped.empty())
    std::printf("sets C^ and D^: not computed: %s\n", result.sets_skipped.c_str());
  if (data.j) PrintTruth(model, *data.j, result);
  if (!args.trace.empty()) {
    WriteTrace(args.trace, model.spec(), DescriptorOf(settings.detector.kind), data, result);
  }
  if (!args.hulls.empty()) WriteHulls(args.hulls, model.state_size(), result);
  const int code = RefineAndReport(model, data, result, settings.sigma, args.refine);
  if (code == 0 && args.refine.refine == "none" &&
      (result.flow_status != EstimatorStatus::kOk || result.jump_status != EstimatorStatus::kOk)) {
    throw RunFailed(fmt::format("identify: the fit is not ok (flow estimator {}, jump estimator {})",
                                ToString(result.flow_status), ToString(result.jump_status)));
  }
  return code;
}

}  // namespace

void AddIdentifyCommand(CLI::App& app, Environment& env) {
  auto args = std::make_shared<IdentifyArgs>();
  CLI::App* cmd = app.add_subcommand("identify", "identify alpha, beta, C and D from measured samples");
  AddModelFlags(*cmd, args->model, "NAME=VALUE: the model's true value (for error metrics)");
  cmd->add_option("--data", args->data,
                  "CSV (RFC 4180): time, then the measured state (y1..yn if present); a column j is taken "
                  "as ground truth, a column run splits the file into runs; repeat --data for several "
                  "runs of one system (alpha, beta shared). Empty, nan or NA state cells: the row is "
                  "left out and the chain restarts")
      ->required();
  AddTextList(*cmd, "--columns", args->columns,
              "columns by header name: t=NAME (time), the state columns in model order, "
              "optionally run=NAME (run column), e.g. t=time,x1,x2");
  cmd->add_option("--max-gap", args->max_gap,
                  "seconds: a step longer than this restarts the chain (no regression or detector "
                  "statistic across it); default 5 x the median step")
      ->each([](const std::string& text) {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (end == text.c_str() || *end != '\0' || !(v > 0.0) || !std::isfinite(v)) {
          BadFlag(fmt::format("--max-gap = {}: must be a number > 0 (seconds)", Abbreviated(text, 40)));
        }
      });
  cmd->add_option("--estimator", args->estimator,
                  PluginHelp("estimator of alpha and beta", AllPlugins<EstimatorKind>()))
      ->capture_default_str();
  cmd->add_option("--detector", args->detector, PluginHelp("jump detector", AllPlugins<DetectorKind>()))
      ->capture_default_str();
  std::vector<std::pair<std::string, CLI::Option*>> option_flags;
  for (const PluginOptionArgument& a : PluginOptionArguments()) {
    const std::string flag = Spelled(a.name, Spelling::kFlag, a.prefix);
    option_flags.emplace_back(
        flag, cmd->add_option(flag, args->options[flag], a.help)->default_str(a.default_text));
  }
  AddNumberList(*cmd, "--flow-noise-shape", args->flow_shape,
                "gtls/frisch: noise covariance shape C of the flow rows [phi, y], row-major, "
                "instead of the one derived from sigma and dt");
  AddNumberList(*cmd, "--jump-noise-shape", args->jump_shape, "gtls/frisch: the same for the jump rows");
  cmd->add_flag("--localize", args->localize,
                "regress each jump at its located instant inside (t-dt, t] (flows forward and "
                "backward with the estimated flow until the jump's known rows agree)");
  cmd->add_flag("--second-pass", args->second_pass,
                "re-classify every sample with the final estimates, re-estimate, report the changes");
  AddSigmaOption(*cmd, args->sigma,
                 "known measurement noise σ (one, or one per state); gtls/frisch estimate it from the data "
                 "when not given");
  CLI::Option* rtol_option =
      cmd->add_option("--data-rtol", args->data_rtol,
                      "residual detector: relative accuracy of the data apart from the noise (simulated "
                      "data: the integrator's rtol, e.g. 1e-12 for `hysid simulate`)")
          ->capture_default_str();
  CLI::Option* atol_option =
      cmd->add_option("--data-atol", args->data_atol,
                      "residual detector: absolute accuracy of the data apart from the noise (simulated "
                      "data: the integrator's atol)")
          ->capture_default_str();
  cmd->add_option("--trace", args->trace,
                  "per-sample CSV: t, the detector's statistic and threshold, gamma, estimates");
  cmd->add_option("--hulls", args->hulls, "CSV of the hull vertices of C^ and D^");
  cmd->callback([args, &env, rtol_option, atol_option, option_flags] {
    args->data_accuracy_given = rtol_option->count() > 0 || atol_option->count() > 0;
    for (const auto& [flag, option] : option_flags) {
      if (option->count() == 0) args->options.erase(flag);
    }
    if (const int code = RunIdentify(*args, env); code != 0) throw CLI::RuntimeError(code);
  });
  AddRefineOptions(cmd, args->refine);
}

}  // namespace hysid::cli
