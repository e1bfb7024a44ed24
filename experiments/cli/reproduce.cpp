// hysid reproduce paper: the experiment of the paper's §5, nominal and with σ = 0.25, writing the data
// behind its Figs. 4–8 as CSV. hysid reproduce example6: the data behind its Fig. 2 (Example 6,
// ξ' = sin ξ: the Euler derivative, the smoothness bound τ and its estimate τ̂ for a few r).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/identify/example6.hpp"
#include "core/identify/identifier.hpp"
#include "core/identify/metrics.hpp"
#include "core/io/csv.hpp"
#include "core/io/files.hpp"
#include "core/io/limits.hpp"
#include "experiments/cli/cli.hpp"
#include "experiments/sweep/run_context.hpp"
#include "sim/measurement.hpp"
#include "sim/simulator.hpp"

namespace hysid::cli {
namespace {

struct ReproduceArgs {
  std::string study = "paper";
  std::string out;  // default: results/<study>
  double sigma = 0.25;
  std::uint64_t seed = 1;
  std::string detector = "paper";
  std::string estimator = "rls";
  double false_alarm = 1e-8;
  bool localize = false;
  bool second_pass = false;
};

struct Experiment {
  const char* name;
  const char* tau_file;
  const char* params_file;
  double sigma;
};

// Fig. 2: ξ0 = 1e-2, δt = 0.5 as in the paper, t from δt to 10 s every 0.01 s.
void RunExample6(const std::string& out_dir) {
  const Example6Options options;
  const double rs[] = {1.0, 2.0, 5.0};
  const std::filesystem::path out(out_dir);
  CheckOutputDirectory("--out", out);
  CsvWriter csv(out / "fig2_smoothness.csv",
                {"t", "xi", "D", "tau", "tau_hat_r1", "tau_hat_r2", "tau_hat_r5"});
  for (long i = 0; i <= 950; ++i) {
    const Example6Point p = Example6At(options.dt + 0.01 * static_cast<double>(i), options);
    const double row[] = {p.t,
                          p.xi,
                          p.euler,
                          p.tau,
                          Example6TauHat(p, rs[0]),
                          Example6TauHat(p, rs[1]),
                          Example6TauHat(p, rs[2])};
    csv.Row(row);
  }
  csv.Commit();
  const nlohmann::json meta = {{"command", "reproduce example6"},
                               {"paper", "Example 6 / Fig. 2: xi' = sin(xi), xi0 = 1e-2, dt = 0.5, k = 1"},
                               {"r", rs},
                               {"context", BuildContext()}};
  WriteFileAtomically(out / "example6.json", meta.dump(2) + "\n");
  std::printf("wrote %s/fig2_smoothness.csv and example6.json\n", out_dir.c_str());
}

// §5.2 settings (r = 220, τ̂0 = 1e5) with the estimator, detector and options of the flags.
IdentifierSettings PaperSettings(const ReproduceArgs& args, const Model& model, double dt) {
  IdentifierSettings settings;
  // Beyond the paper: the errors-in-variables estimators, with their defaults (noise shapes from the σ
  // estimated from the data, see core/identify/identifier.hpp), another detector, jump
  // localisation, a second pass.
  SetPluginKinds(args.estimator, args.detector, &settings);
  settings.detector.r = 220.0;
  settings.detector.tau0 = 1e5;
  settings.detector.false_alarm = args.false_alarm;
  settings.localize = args.localize;
  settings.second_pass = args.second_pass;
  // The data are simulated at the simulator's default tolerances: the residual detector's data accuracy.
  settings.data_rtol = SimOptions{}.rtol;
  settings.data_atol = SimOptions{}.atol;
  try {
    Identifier check(model, dt, settings);
  } catch (const std::invalid_argument& e) {
    BadFlag(fmt::format("--estimator/--detector/--false-alarm: {}", e.what()));
  }
  return settings;
}

// Fig. 4: position and velocity, and the jumps.
void WriteFig4(const std::filesystem::path& out, const Trajectory& traj) {
  CsvWriter csv(out / "fig4_trajectory.csv", {"t", "j", "x1", "x2"});
  for (long k = 0; k < traj.size(); ++k) {
    const double row[] = {traj.t[std::size_t(k)], double(traj.j[std::size_t(k)]), traj.x(0, k), traj.x(1, k)};
    csv.Row(row);
  }
  csv.Commit();
  CsvWriter jumps(out / "fig4_jumps.csv", {"j", "t_jump", "pre_x1", "pre_x2", "post_x1", "post_x2"});
  for (const JumpRecord& j : traj.jumps) {
    const double row[] = {double(j.j), j.t, j.pre[0], j.pre[1], j.post[0], j.post[1]};
    jumps.Row(row);
  }
  jumps.Commit();
}

// The τ file (D, τ̂, rτ, e_τ per sample). Returns the mean relative error |τ̂ − rτ|/(rτ) over the
// samples where τ̂ comes from α̂ (not τ̂0), and over the true flow samples from t = 1 s on (after the
// estimator's start-up transient); NaN for other detectors.
std::pair<double, double> WriteTauFile(const std::filesystem::path& path, const Trajectory& traj,
                                       const std::vector<double>& tau, const DetectorSettings& detector,
                                       const IdentifyResult& res) {
  const bool paper_detector = detector.kind == DetectorKind::kPaper;
  CsvWriter tcsv(path, {"t", "D", "tau_hat", "r_tau", "e_tau", "gamma", "true_jump"});
  double rel_sum = 0.0, rel_flow_sum = 0.0;
  long rel_n = 0, rel_flow_n = 0;
  for (long k = 0; k < traj.size(); ++k) {
    const auto u = std::size_t(k);
    const double rt = detector.r * tau[u];
    const double et = std::abs(res.threshold[u] - rt);
    const bool true_jump = k > 0 && traj.j[u] != traj.j[u - 1];
    const double row[] = {traj.t[u], res.statistic[u],     res.threshold[u],     rt,
                          et,        double(res.gamma[u]), true_jump ? 1.0 : 0.0};
    tcsv.Row(row);
    if (paper_detector && k > 0 && res.threshold[u] != detector.tau0 && rt > 0) {
      rel_sum += et / rt;
      ++rel_n;
      if (!true_jump && traj.t[u] >= 1.0) rel_flow_sum += et / rt, ++rel_flow_n;
    }
  }
  tcsv.Commit();
  return {rel_n ? rel_sum / double(rel_n) : NAN, rel_flow_n ? rel_flow_sum / double(rel_flow_n) : NAN};
}

void WriteParamsFile(const std::filesystem::path& path, const Model& model, const Trajectory& traj,
                     const IdentifyResult& res) {
  CsvWriter pcsv(path, {"t", "a_hat", "b_hat", "lambda_hat", "mu_hat", "e_alpha", "e_beta"});
  for (long k = 0; k < traj.size(); ++k) {
    const Vec a = res.alpha_trace.col(k), b = res.beta_trace.col(k);
    const double row[] = {traj.t[std::size_t(k)],   a[1], a[2], b[1], b[2], (model.alpha() - a).norm(),
                          (model.beta() - b).norm()};
    pcsv.Row(row);
  }
  pcsv.Commit();
}

// One experiment (nominal or noisy): its files, its summary row, a line on stdout; returns its
// run.json entry.
nlohmann::json RunPaperExperiment(const Experiment& ex, const ReproduceArgs& args, const Model& model,
                                  const Trajectory& traj, const IdentifierSettings& settings,
                                  const std::vector<double>& tau, const std::filesystem::path& out,
                                  CsvWriter& summary) {
  const Mat y = AddMeasurementNoisePerSample(traj.x, Vec::Constant(2, ex.sigma), NoiseKey{args.seed, 0});
  const IdentifyResult res = Identify(model, y, traj.dt, settings, IdentifyOptions{.trace = true});
  const Confusion c = CompareJumps(traj.j, res.gamma);
  const ParameterErrors e = CompareParameters(model, res.alpha_hat, res.beta_hat);
  const auto [mean_rel, mean_rel_flow] = WriteTauFile(out / ex.tau_file, traj, tau, settings.detector, res);
  WriteParamsFile(out / ex.params_file, model, traj, res);
  const double srow[] = {ex.sigma,
                         res.alpha_hat[1],
                         res.alpha_hat[2],
                         res.beta_hat[1],
                         res.beta_hat[2],
                         e.e_alpha,
                         e.e_beta,
                         double(res.jumps_detected),
                         double(c.tp + c.fn),
                         double(c.fp),
                         double(c.fn),
                         mean_rel,
                         mean_rel_flow};
  std::vector<std::string> cells{ex.name};
  for (double v : srow) cells.push_back(fmt::format("{:.17g}", v));
  summary.TextRow(cells);
  std::printf(
      "%-8s sigma %-5g a^ %.6f b^ %.6f lambda^ %.6f mu^ %.6f | e_alpha %.3g e_beta %.3g | "
      "jumps %ld/%ld, false %ld, missed %ld | mean rel. tau^ error %.2f%% (t >= 1 s: %.2f%%)\n",
      ex.name, ex.sigma, res.alpha_hat[1], res.alpha_hat[2], res.beta_hat[1], res.beta_hat[2], e.e_alpha,
      e.e_beta, res.jumps_detected, c.tp + c.fn, c.fp, c.fn, 100 * mean_rel, 100 * mean_rel_flow);
  if (res.second_pass) {
    std::printf("         second pass: %ld samples flow -> jump, %ld jump -> flow\n",
                res.reclassified_to_jump, res.reclassified_to_flow);
  }
  nlohmann::json entry = {
      {"name", ex.name}, {"sigma", ex.sigma}, {"tau", ex.tau_file}, {"params", ex.params_file}};
  if (res.noise_sigma.size()) {  // gtls / frisch: the σ their noise shapes came from
    entry["noise_shape_sigma"] = std::vector<double>(res.noise_sigma.begin(), res.noise_sigma.end());
    entry["noise_shape_sigma_estimated"] = res.noise_sigma_estimated;
  }
  return entry;
}

// reproduce paper writes summary.csv and run.json: a directory of another study (a sweep's run directory,
// a merge, another command's run.json, a summary.csv without run.json) is refused, not overwritten.
void CheckPaperTarget(const std::filesystem::path& out) {
  std::error_code ec;
  const auto refuse = [&](const std::string& what) {
    BadFlag(
        fmt::format("--out {}: {}; reproduce paper writes only into a new directory or over an earlier "
                    "reproduce paper: give another --out",
                    out.string(), what));
  };
  for (const char* name : {"sweep.json", "trials.journal", "trials.csv"}) {
    if (std::filesystem::exists(out / name, ec)) refuse(fmt::format("holds {} of a sweep", name));
  }
  if (!std::filesystem::exists(out / "run.json", ec)) {
    if (std::filesystem::exists(out / "summary.csv", ec))
      refuse("holds summary.csv of an unknown study (no run.json)");
    return;
  }
  std::ifstream in(out / "run.json");
  const nlohmann::json old = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  const bool ours = old.is_object() && old.contains("command") && old["command"] == "reproduce paper";
  if (!ours) refuse("holds the run.json of another study");
}

void RunReproduce(ReproduceArgs args, const Environment& env) {
  if (args.out.empty()) args.out = "results/" + args.study;
  if (args.study == "example6") return RunExample6(args.out);
  if (args.study != "paper") {
    BadFlag(fmt::format("reproduce {}: unknown study (known: paper, example6)", args.study));
  }
  if (!(args.sigma >= 0) || !std::isfinite(args.sigma)) {
    BadFlag(fmt::format("--sigma = {}: must be finite and >= 0", args.sigma));
  }
  // §5.2: a = 5, b = 0.1, λ = 0.99, μ = 0, ξ0 = (20, 0), 20 s, δt = 0.5 ms, r = 220, τ̂0 = 1e5.
  Model model = env.models.Make("impact-msd");
  for (const char* p : {"a=5", "b=0.1", "lambda=0.99", "mu=0"}) model.SetParameter(std::string_view(p));
  const double dt = 5e-4, t_end = 20.0;
  CheckLimit(kMaxSamples, static_cast<std::int64_t>(t_end / dt) + 1,
             fmt::format("reproduce paper: t_end {} / dt {} of Sec. 5.2", t_end, dt));
  const IdentifierSettings settings = PaperSettings(args, model, dt);
  Vec x0(2);
  x0 << 20.0, 0.0;
  const std::filesystem::path out(args.out);
  CheckOutputDirectory("--out", out);
  CheckPaperTarget(out);
  const Trajectory traj = Simulate(model, x0, SampleGrid{t_end, dt});
  if (!traj.status.completed()) {
    throw std::runtime_error(fmt::format("simulation of the §5 system failed: {}", traj.status.message));
  }
  WriteFig4(out, traj);
  const std::vector<double> tau = TrueSmoothnessBound(model, traj.x, settings.detector);
  CsvWriter summary(
      out / "summary.csv",
      {"experiment", "sigma", "a_hat", "b_hat", "lambda_hat", "mu_hat", "e_alpha", "e_beta", "jumps_detected",
       "true_jumps", "false_jumps", "missed_jumps", "mean_rel_tau_error", "mean_rel_tau_error_after_1s"});
  nlohmann::json experiments = nlohmann::json::array();
  for (const Experiment& ex :
       {Experiment{"nominal", "fig5_tau_nominal.csv", "fig6_params_nominal.csv", 0.0},
        Experiment{"noisy", "fig7_tau_noisy.csv", "fig8_params_noisy.csv", args.sigma}}) {
    experiments.push_back(RunPaperExperiment(ex, args, model, traj, settings, tau, out, summary));
  }
  summary.Commit();
  const nlohmann::json meta = {
      {"command", "reproduce paper"},
      {"paper", "Sec. 5.2: a=5, b=0.1, lambda=0.99, mu=0, x0=(20,0), 20 s, dt=0.5 ms, r=220, tau0=1e5"},
      {"seed", args.seed},
      {"experiments", experiments},
      {"estimator", args.estimator},
      {"detector", args.detector},
      {"false_alarm", args.false_alarm},
      {"localize", args.localize},
      {"second_pass", args.second_pass},
      {"p0", settings.flow_estimator.p0},
      {"model", ResolvedModelJson(model, {x0[0], x0[1]}, {dt}, t_end)},
      {"context", BuildContext()},
  };
  WriteFileAtomically(out / "run.json", meta.dump(2) + "\n");
  std::printf(
      "wrote %s/{fig4_trajectory,fig4_jumps,fig5_tau_nominal,fig6_params_nominal,"
      "fig7_tau_noisy,fig8_params_noisy,summary}.csv and run.json\n",
      args.out.c_str());
}

}  // namespace

void AddReproduceCommand(CLI::App& app, Environment& env) {
  auto args = std::make_shared<ReproduceArgs>();
  CLI::App* cmd =
      app.add_subcommand("reproduce", "re-run a study of the paper (paper = Sec. 5, example6 = Fig. 2)");
  cmd->add_option("study", args->study, "paper or example6")->capture_default_str();
  cmd->add_option("--out", args->out, "output directory (default: results/<study>)");
  std::vector<CLI::Option*> paper_only;  // what example6 (a closed-form figure) does not read
  paper_only.push_back(
      cmd->add_option("--sigma", args->sigma, "noise of the noisy experiment")->capture_default_str());
  paper_only.push_back(cmd->add_option("--seed", args->seed, "noise seed (0 to 2^64-1)")
                           ->capture_default_str()
                           ->transform(NonNegativeInteger));
  paper_only.push_back(cmd->add_option("--estimator", args->estimator,
                                       PluginHelp("estimator of alpha and beta (rls as published)",
                                                  AllPlugins<EstimatorKind>()))
                           ->capture_default_str());
  paper_only.push_back(
      cmd->add_option("--detector", args->detector,
                      "paper (as published, r = 220) or residual (tuning-free; the tau columns "
                      "then hold |z| and its quantile, and the tau error is not computed)")
          ->capture_default_str());
  CLI::Option* false_alarm =
      cmd->add_option("--false-alarm", args->false_alarm, "residual detector: false-alarm probability")
          ->capture_default_str();
  paper_only.push_back(false_alarm);
  paper_only.push_back(
      cmd->add_flag("--localize", args->localize, "regress each jump at its located instant"));
  paper_only.push_back(cmd->add_flag("--second-pass", args->second_pass,
                                     "re-classify with the final estimates and re-estimate"));
  cmd->callback([args, &env, paper_only, false_alarm] {
    for (const CLI::Option* o : paper_only) {
      if (args->study == "example6" && o->count() > 0) {
        BadFlag(fmt::format("{}: reproduce example6 does not read it (it reads --out only)", o->get_name()));
      }
    }
    IdentifierSettings kinds;  // the names, refused as `identify` refuses them
    SetPluginKinds(args->estimator, args->detector, &kinds);
    if (false_alarm->count() > 0 && !DescriptorOf(kinds.detector.kind).Reads("false_alarm")) {
      BadFlag(fmt::format("--false-alarm: the detector '{}' does not read it", args->detector));
    }
    RunReproduce(*args, env);
  });
}

}  // namespace hysid::cli
