// hysid identify: the paper's identifier on measured samples from a CSV.
#include <algorithm>
#include <cmath>
#include <utility>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "core/io/csv.hpp"
#include "core/io/files.hpp"
#include "core/identify/identifier.hpp"
#include "core/identify/metrics.hpp"
#include "core/sets/set_metrics.hpp"
#include "experiments/cli/cli.hpp"
#include "core/io/sample_data.hpp"

namespace hysid::cli {
namespace {

struct IdentifyArgs {
  std::string model = "impact-msd";
  std::vector<std::string> params;
  std::string data;
  std::string estimator = "rls";
  double forgetting = 1.0;
  EstimatorSettings eiv;             // gtls / frisch options (defaults as documented there)
  std::vector<double> flow_shape, jump_shape;  // user noise shapes C, row-major
  std::string detector = "residual";
  double r = 220.0;
  double tau0 = 1e5;
  std::string bound = "auto";
  double false_alarm = 1e-8;
  bool localize = false;
  bool second_pass = false;
  double jump_forgetting = 1.0;
  std::vector<double> sigma;
  double data_rtol = 0.0, data_atol = 0.0;
  bool data_accuracy_given = false;  // --data-rtol or --data-atol on the command line
  std::string trace;
  std::string hulls;
  RefineArgs refine;  // --refine, --json (identify_refine.cpp)
};

std::vector<std::string> UnknownNames(const std::vector<Parameter>& params) {
  std::vector<std::string> names;
  for (const Parameter& p : params) {
    if (!p.known) names.push_back(p.name);
  }
  return names;
}

int RunIdentify(const IdentifyArgs& args, const Environment& env) {
  const Model model = MakeModel(env, args.model, args.params);
  const ModelSpec& spec = model.spec();
  const int n = model.state_size();
  IdentifierSettings settings;
  for (EstimatorSettings* e : {&settings.flow_estimator, &settings.jump_estimator}) {
    e->name = args.estimator;
    e->refactor_every = args.eiv.refactor_every;
    e->frisch_box = args.eiv.frisch_box;
    e->frisch_point = args.eiv.frisch_point;
    e->frisch_confidence = args.eiv.frisch_confidence;
  }
  settings.flow_estimator.window = args.eiv.window;
  settings.flow_estimator.forgetting = args.forgetting;
  settings.jump_estimator.forgetting = args.jump_forgetting;
  auto shape = [](const std::vector<double>& v, const char* flag) {
    if (v.empty()) return Mat();
    RequireFinite(flag, v);
    const auto m = static_cast<Eigen::Index>(std::lround(std::sqrt(double(v.size()))));
    if (m * m != static_cast<Eigen::Index>(v.size())) {
      BadFlag(fmt::format("{} has {} values: give a square matrix (parameters + 1)^2, row-major",
                          flag, v.size()));
    }
    return Mat(Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
        v.data(), m, m));
  };
  settings.flow_estimator.noise_shape = shape(args.flow_shape, "--flow-noise-shape");
  settings.jump_estimator.noise_shape = shape(args.jump_shape, "--jump-noise-shape");
  settings.detector.name = args.detector;
  settings.detector.r = args.r;
  settings.detector.tau0 = args.tau0;
  settings.detector.bound = args.bound;
  settings.detector.false_alarm = args.false_alarm;
  settings.localize = args.localize;
  settings.second_pass = args.second_pass;
  // Checked here too (the identifier checks the fields) so that the message names the flag.
  for (const auto& [flag, value] :
       {std::pair{"--data-rtol", args.data_rtol}, std::pair{"--data-atol", args.data_atol}}) {
    if (!(value >= 0.0) || !std::isfinite(value)) {
      BadFlag(fmt::format("{} = {}: must be finite and >= 0", flag, value));
    }
  }
  settings.data_rtol = args.data_rtol;
  settings.data_atol = args.data_atol;
  if (std::string e; !settings.detector.IsValid(&e)) {
    BadFlag(fmt::format("--r/--tau0/--bound/--false-alarm: {}", e));
  }
  if (std::string e; !settings.flow_estimator.IsValid(&e)) {
    BadFlag(fmt::format("--forgetting/--window/--refactor-every/--frisch-*: {}", e));
  }
  if (std::string e; !settings.jump_estimator.IsValid(&e)) {
    BadFlag(fmt::format("--jump-forgetting: {}", e));
  }
  if (!args.sigma.empty()) {
    RequireFinite("--sigma", args.sigma);
    settings.sigma = Vec(n);
    if (args.sigma.size() == 1) {
      settings.sigma.setConstant(args.sigma[0]);
    } else if (static_cast<int>(args.sigma.size()) == n) {
      settings.sigma = Eigen::Map<const Vec>(args.sigma.data(), n);
    } else {
      BadFlag(fmt::format("--sigma has {} values; give one, or one per state ({})",
                          args.sigma.size(), n));
    }
    if ((settings.sigma.array() < 0).any()) BadFlag("--sigma: must be >= 0");
  }

  // Settings errors (unknown estimator or detector, ...) before the data is read.
  try {
    Identifier check(model, 1.0, settings);
  } catch (const std::invalid_argument& e) {
    BadFlag(fmt::format("--estimator/--detector/--*-noise-shape: {}", e.what()));
  }
  const SampleData data = ReadSampleData(args.data, n);
  // Data written by `hysid simulate` has a sidecar FILE.json with the solver's tolerances: without
  // --data-rtol/--data-atol they are the data's accuracy (noise-free data is then as exact as that).
  std::string accuracy_source = args.data_accuracy_given ? "as given" : "none given";
  if (!args.data_accuracy_given) {
    const std::filesystem::path sidecar = std::filesystem::path(args.data).replace_extension(".json");
    std::ifstream in(sidecar);
    if (in) {
      const nlohmann::json meta = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
      if (meta.is_object() && meta.value("command", "") == "simulate" && meta.contains("solver") &&
          meta["solver"].is_object() && meta["solver"].value("rtol", -1.0) >= 0.0 &&
          meta["solver"].value("atol", -1.0) >= 0.0) {
        settings.data_rtol = meta["solver"]["rtol"].get<double>();
        settings.data_atol = meta["solver"]["atol"].get<double>();
        accuracy_source = fmt::format("the solver tolerances in {}", sidecar.string());
      }
    }
  }
  if (!args.trace.empty()) CheckOutputPath("--trace", args.trace);
  if (!args.hulls.empty()) CheckOutputPath("--hulls", args.hulls);
  IdentifyOptions options;
  options.trace = !args.trace.empty();
  const IdentifyResult result = Identify(model, data.y, data.dt, settings, options);

  std::printf("model %s, data %s (%s), %zu samples, dt = %.6g\n", spec.name.c_str(),
              data.path.c_str(), fmt::format("{}", fmt::join(data.state_columns, ",")).c_str(),
              data.t.size(), data.dt);
  if (args.detector == "paper") {
    std::printf("estimator %s, detector paper (r = %g, tau0 = %g, bound %s)", args.estimator.c_str(),
                args.r, args.tau0, args.bound.c_str());
  } else {
    std::printf(
        "estimator %s, detector %s (false-alarm probability %g; data accuracy rtol %g, atol %g: %s)",
        args.estimator.c_str(), args.detector.c_str(), args.false_alarm, settings.data_rtol,
        settings.data_atol, accuracy_source.c_str());
  }
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
  // frisch: the solution boxes of the unknowns, in the order printed above.
  for (const auto& [box, what] : {std::pair{&result.flow_box, "alpha"}, std::pair{&result.jump_box, "beta"}}) {
    if (box->size() == 0) continue;
    std::printf("frisch box %s:", what);
    for (Eigen::Index i = 0; i < box->rows(); ++i) std::printf(" [%.6g, %.6g]", (*box)(i, 0), (*box)(i, 1));
    std::printf("\n");
  }
  if (args.localize) {
    std::printf("jumps localised: %ld of %ld\n", result.jumps_localized, result.jumps_detected);
  }
  if (result.second_pass) {
    std::printf("second pass: %ld samples flow -> jump, %ld jump -> flow (first pass: %ld jumps)\n",
                result.reclassified_to_jump, result.reclassified_to_flow,
                static_cast<long>(std::count(result.first_pass_gamma.begin(),
                                             result.first_pass_gamma.end(), 1)));
  }
  if (data.j) {
    const Confusion c = CompareJumps(*data.j, result.gamma);
    const ParameterErrors e = CompareParameters(model, result.alpha_hat, result.beta_hat);
    std::printf("truth (column j): %ld true jumps; TP %ld, FP %ld, FN %ld, TN %ld\n", c.tp + c.fn,
                c.tp, c.fp, c.fn, c.tn);
    std::printf("  misclassification %.6g, precision %.6g, recall %.6g\n", c.misclassification(),
                c.precision(), c.recall());
    std::printf("  e_alpha %.6g, e_beta %.6g (relative %.6g, %.6g) against the model's values\n",
                e.e_alpha, e.e_beta, e.rel_alpha, e.rel_beta);
    // Ĉ and D̂ against the model's C and D.
    const SetMetrics sm = CompareSets(model, result.flow_hull, result.jump_hull);
    std::printf("  sets: C^ has %ld vertices (%s %.6g), %.6g of it outside C; D^ has %ld vertices, ",
                static_cast<long>(result.flow_hull.cols()), n >= 3 ? "volume" : "area", result.flow_hull_volume,
                sm.flow_outside_share, static_cast<long>(result.jump_hull.cols()));
    if (model.has_jump_set_distance()) {
      std::printf("within %.6g of D (one-sided Hausdorff)\n", sm.jump_hausdorff);
    } else {
      std::printf("distance to D unknown (the model has no DistanceToJumpSet)\n");
    }
  }

  if (!args.trace.empty()) {
    // paper: D_δt ξ and τ̂; residual: max |z| and the test's quantile q.
    std::vector<std::string> header{"t", "D", "tau_hat", "gamma"};
    if (args.detector == "residual") header = {"t", "z", "q", "gamma"};
    const auto an = UnknownNames(spec.alpha), bn = UnknownNames(spec.beta);
    for (const auto& s : an) header.push_back(s + "_hat");
    for (const auto& s : bn) header.push_back(s + "_hat");
    if (data.j) {
      header.push_back("j");
      header.push_back("true_jump");
    }
    CsvWriter csv(args.trace, header);
    std::vector<double> row(header.size());
    for (std::size_t k = 0; k < data.t.size(); ++k) {
      std::size_t c = 0;
      row[c++] = data.t[k];
      row[c++] = result.statistic[k];
      row[c++] = result.threshold[k];
      row[c++] = result.gamma[k];
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
    std::printf("wrote %s\n", args.trace.c_str());
  }
  if (!args.hulls.empty()) {
    std::vector<std::string> header{"set", "vertex"};
    for (int i = 1; i <= n; ++i) header.push_back(fmt::format("x{}", i));
    CsvWriter csv(args.hulls, header);
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
    std::printf("wrote %s (set 0 = flow hull C^, set 1 = jump hull D^, vertices in order)\n",
                args.hulls.c_str());
  }
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
  cmd->add_option("--model", args->model, "model name (see `hysid models`)")->capture_default_str();
  cmd->add_option("--param", args->params, "NAME=VALUE: the model's true value (for error metrics)");
  cmd->add_option("--data", args->data, "CSV: time, then the measured state (y1..yn if present); "
                                        "a column j is taken as ground truth")
      ->required();
  cmd->add_option("--estimator", args->estimator,
                  "rls, gtls (recursive generalized TLS, noise shape C from sigma and dt) or frisch "
                  "(recursive Frisch scheme: a solution box and a point in it)")
      ->capture_default_str();
  cmd->add_option("--window", args->eiv.window,
                  "frisch: window of the alpha estimator in rows (0 = growing; beta: always growing)")
      ->capture_default_str();
  cmd->add_option("--frisch-box", args->eiv.frisch_box,
                  "frisch: cumulative (box of the simplex of all rows) or intersect (BBRF)")
      ->capture_default_str();
  cmd->add_option("--frisch-point", args->eiv.frisch_point,
                  "frisch: rls (RLS clamped into the boxes) or centre (of the box)")
      ->capture_default_str();
  cmd->add_option("--frisch-confidence", args->eiv.frisch_confidence,
                  "frisch: confidence of the sampling allowance added to the boxes (0 = none)")
      ->capture_default_str();
  cmd->add_option("--refactor-every", args->eiv.refactor_every,
                  "gtls: exact refactorisation every this many rows")
      ->capture_default_str();
  cmd->add_option("--flow-noise-shape", args->flow_shape,
                  "gtls/frisch: noise covariance shape C of the flow rows [phi, y], row-major, "
                  "instead of the one derived from sigma and dt")
      ->delimiter(',');
  cmd->add_option("--jump-noise-shape", args->jump_shape,
                  "gtls/frisch: the same for the jump rows")
      ->delimiter(',');
  cmd->add_option("--forgetting", args->forgetting, "forgetting factor of the alpha estimator")
      ->capture_default_str();
  cmd->add_option("--detector", args->detector,
                  "jump detector: paper (the paper's smoothness bound, tuned by --r) or residual "
                  "(tuning-free: one-step prediction residual of the flow model, tested at "
                  "--false-alarm)")
      ->capture_default_str();
  cmd->add_option("--false-alarm", args->false_alarm,
                  "residual detector: false-alarm probability per flow sample, in (0, 0.5)")
      ->capture_default_str();
  cmd->add_flag("--localize", args->localize,
                "regress each jump at its located instant inside (t-dt, t] (flows forward and "
                "backward with the estimated flow until the jump's known rows agree)");
  cmd->add_flag("--second-pass", args->second_pass,
                "re-classify every sample with the final estimates, re-estimate, report the changes");
  cmd->add_option("--jump-forgetting", args->jump_forgetting, "forgetting factor of the beta estimator")
      ->capture_default_str();
  cmd->add_option("--r", args->r, "paper detector: multiplicative constant r > 1")->capture_default_str();
  cmd->add_option("--tau0", args->tau0, "paper detector: initial smoothness bound")->capture_default_str();
  cmd->add_option("--bound", args->bound, "paper detector: auto, paper or homogeneous")
      ->capture_default_str();
  cmd->add_option("--sigma", args->sigma,
                  "known measurement noise σ (one, or one per state); gtls/frisch estimate it "
                  "from the data when not given")
      ->delimiter(',');
  CLI::Option* rtol_option = cmd->add_option("--data-rtol", args->data_rtol,
                  "residual detector: relative accuracy of the data apart from the noise (simulated "
                  "data: the integrator's rtol, e.g. 1e-12 for `hysid simulate`)")
      ->capture_default_str();
  CLI::Option* atol_option = cmd->add_option("--data-atol", args->data_atol,
                  "residual detector: absolute accuracy of the data apart from the noise (simulated "
                  "data: the integrator's atol)")
      ->capture_default_str();
  cmd->add_option("--trace", args->trace, "per-sample CSV: t, D, tau_hat, gamma, estimates");
  cmd->add_option("--hulls", args->hulls, "CSV of the hull vertices of C^ and D^");
  cmd->callback([args, &env, rtol_option, atol_option] {
    args->data_accuracy_given = rtol_option->count() > 0 || atol_option->count() > 0;
    if (const int code = RunIdentify(*args, env); code != 0) throw CLI::RuntimeError(code);
  });
  AddRefineOptions(cmd, args->refine);
}

}  // namespace hysid::cli
