// hysid_eiv_study: errors-in-variables estimators on the paper's §5 system.
//
// System:   impact-msd with its defaults (a = 5, b = 0.1, λ = 0.99, μ = 0; ξ0 = (20, 0); 20 s;
//           δt = 0.5 ms; 14 jumps), simulated once with Simulate (CVODE, rtol = atol = 1e-12).
// Noise:    y = ξ + e, e ~ N(0, σ²I) from AddMeasurementNoisePerSample with NoiseKey{seed, trial}.
// Method:   the Identifier (Algorithms 1 + 2, paper detector r = 220, τ̂0 = 1e5 as `hysid reproduce
//           paper`, no hulls) with the same estimator for α and β. gtls and frisch get their noise
//           shapes from WithNoiseShapes with the true σ (gtls: C; frisch: its exact columns).
//           frisch: flow window --window rows, jump window --jump-window (0 = growing), box and
//           point rules --frisch-box / --frisch-point. --oracle labels samples with the true jumps
//           (γ(t) = [j(t) ≠ j(t − δt)]) instead of the detector, isolating the estimators.
// Outputs:  per σ and estimator, over --trials seeds: e_α = ‖α − α̂‖, e_β = ‖β − β̂‖ (mean ± 95 % CI,
//           1.96·sd/√n), the mean â, b̂, λ̂, μ̂ (bias), how many runs ended with status ok, and for
//           frisch how often its boxes contain the true (a, b) and (λ, μ), and the paired difference
//           of each estimator's e_α, e_β from rls's in the same trial. One line per cell on
//           stdout; with --out DIR also DIR/trials.csv (one row per trial and estimator),
//           DIR/summary.csv (one row per cell) and DIR/run.json (command, seed, settings, context).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

#include "core/io/csv.hpp"
#include "core/estimators/estimator.hpp"
#include "core/estimators/frisch.hpp"
#include "core/identify/identifier.hpp"
#include "core/identify/metrics.hpp"
#include "core/model/builtin/impact_msd.hpp"
#include "core/model/regression.hpp"
#include "experiments/sweep/run_context.hpp"
#include "sim/measurement.hpp"
#include "sim/simulator.hpp"

namespace {

using hysid::Vec;

struct Trial {
  double e_alpha = 0, e_beta = 0, a = 0, b = 0, lambda = 0, mu = 0;
  int flow_ok = 0, jump_ok = 0, jumps_detected = 0;
  int flow_covered = -1, jump_covered = -1;  // frisch: true (a, b) / (λ, μ) inside the box
  double flow_box_width_a = NAN, jump_box_width_lambda = NAN;
};

struct Stat {
  double mean = 0, ci = 0;
};

template <class F>
Stat Summarise(const std::vector<Trial>& trials, F get) {
  double m = 0.0;
  for (const Trial& t : trials) m += get(t);
  const double n = double(trials.size());
  m /= n;
  double s = 0.0;
  for (const Trial& t : trials) s += (get(t) - m) * (get(t) - m);
  s = trials.size() > 1 ? std::sqrt(s / (n - 1)) : 0.0;
  return {m, 1.96 * s / std::sqrt(n)};
}

}  // namespace

int main(int argc, char** argv) {
  using namespace hysid;
  CLI::App app{"EIV estimators on the paper's Sec. 5 system: e_alpha, e_beta over seeds"};
  std::vector<double> sigmas = {0.25, 1.0, 2.0};
  std::vector<std::string> names = {"rls", "gtls", "frisch"};
  int trials = 100;
  std::uint64_t seed = 1;
  int window = EstimatorSettings{}.window;
  int jump_window = 0;
  std::string frisch_box = "cumulative";
  std::string frisch_point = "rls";
  double frisch_confidence = EstimatorSettings{}.frisch_confidence;
  bool oracle = false;
  std::string out;
  app.add_option("--sigma", sigmas, "noise levels (comma separated)")->delimiter(',')
      ->capture_default_str();
  app.add_option("--estimators", names, "estimators (comma separated)")->delimiter(',')
      ->capture_default_str();
  app.add_option("--trials", trials, "seeds per sigma")->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--seed", seed, "master seed")->capture_default_str();
  app.add_option("--window", window, "frisch flow window (rows)")->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--jump-window", jump_window, "frisch jump window (rows, 0 = growing)")
      ->capture_default_str();
  app.add_option("--frisch-box", frisch_box, "cumulative or intersect")->capture_default_str();
  app.add_option("--frisch-point", frisch_point, "rls or centre")->capture_default_str();
  app.add_option("--frisch-confidence", frisch_confidence,
                 "confidence of the sampling allowance of the frisch boxes (0 = none)")
      ->capture_default_str();
  app.add_flag("--oracle", oracle,
               "label samples with the true jumps (isolates the estimators from the detector)");
  app.add_option("--out", out, "directory for trials.csv, summary.csv, run.json");
  CLI11_PARSE(app, argc, argv);
  for (double s : sigmas) {
    if (!(s >= 0.0) || !std::isfinite(s)) {
      std::fprintf(stderr, "--sigma = %g: must be finite and >= 0\n", s);
      return 2;
    }
  }

  const Model model(ImpactMsd{});
  const ModelSpec& spec = model.spec();
  Vec x0(2);
  x0 << spec.default_x0[0], spec.default_x0[1];
  const double dt = spec.default_dt;
  const Trajectory traj = Simulate(model, x0, SampleGrid{spec.default_t_end, dt});
  if (!traj.status.completed()) {
    std::fprintf(stderr, "simulation failed: %s\n", traj.status.message.c_str());
    return 1;
  }
  IdentifierSettings base;
  base.detector.r = 220.0;
  base.detector.tau0 = 1e5;
  base.sets = false;
  base.flow_estimator.window = window;
  base.jump_estimator.window = jump_window;
  base.flow_estimator.frisch_box = base.jump_estimator.frisch_box = frisch_box;
  base.flow_estimator.frisch_point = base.jump_estimator.frisch_point = frisch_point;
  base.flow_estimator.frisch_confidence = base.jump_estimator.frisch_confidence = frisch_confidence;
  for (const std::string& name : names) {
    IdentifierSettings s = base;
    s.flow_estimator.name = s.jump_estimator.name = name;
    try {
      Identifier check(model, dt, s);
    } catch (const std::invalid_argument& e) {
      std::fprintf(stderr, "settings: %s\n", e.what());
      return 2;
    }
  }
  const std::string labels = oracle ? "true jumps (oracle)" : "paper detector r = 220";
  std::printf("# impact-msd defaults: a = %g, b = %g, lambda = %g, mu = %g; %ld samples, %zu jumps; "
              "seed %llu, %d trials, frisch window %d / jump window %d, box %s, point %s, confidence %g; "
              "labels: %s\n",
              model.alpha()[1], model.alpha()[2], model.beta()[1], model.beta()[2], traj.size(),
              traj.jumps.size(), static_cast<unsigned long long>(seed), trials, window, jump_window,
              frisch_box.c_str(), frisch_point.c_str(), frisch_confidence, labels.c_str());
  std::printf("%-6s %-7s %-22s %-22s %-9s %-9s %-9s %-9s %-8s %-18s %s\n", "sigma", "est",
              "e_alpha (95% CI)", "e_beta (95% CI)", "mean a^", "mean b^", "mean la^", "mean mu^",
              "ok f/j", "frisch box covers", "paired e_alpha, e_beta - rls (95% CI)");

  const std::vector<std::string> trial_header = {
      "sigma", "estimator", "trial", "e_alpha", "e_beta", "a_hat", "b_hat", "lambda_hat", "mu_hat",
      "flow_ok", "jump_ok", "jumps_detected", "flow_box_covers", "jump_box_covers",
      "flow_box_width_a", "jump_box_width_lambda"};
  const std::vector<std::string> summary_header = {
      "sigma", "estimator", "trials", "e_alpha_mean", "e_alpha_ci95", "e_beta_mean", "e_beta_ci95",
      "a_hat_mean", "a_hat_ci95", "b_hat_mean", "b_hat_ci95", "lambda_hat_mean", "lambda_hat_ci95",
      "mu_hat_mean", "mu_hat_ci95", "flow_ok", "jump_ok", "flow_box_coverage", "jump_box_coverage",
      "e_alpha_minus_rls_mean", "e_alpha_minus_rls_ci95", "e_beta_minus_rls_mean",
      "e_beta_minus_rls_ci95"};
  std::unique_ptr<CsvWriter> trial_csv, summary_csv;
  if (!out.empty()) {
    trial_csv = std::make_unique<CsvWriter>(std::filesystem::path(out) / "trials.csv", trial_header);
    summary_csv = std::make_unique<CsvWriter>(std::filesystem::path(out) / "summary.csv", summary_header);
  }
  auto num = [](double v) { return fmt::format("{:.10g}", v); };
  const std::size_t rls_index =
      std::size_t(std::find(names.begin(), names.end(), "rls") - names.begin());

  for (double sigma : sigmas) {
    const Vec sig = Vec::Constant(2, sigma);
    std::vector<std::vector<Trial>> cells(names.size(), std::vector<Trial>(std::size_t(trials)));
    tbb::parallel_for(0, trials, [&](int trial) {
      const Mat y = AddMeasurementNoisePerSample(traj.x, sig, NoiseKey{seed, std::uint64_t(trial)});
      for (std::size_t e = 0; e < names.size(); ++e) {
        IdentifierSettings settings = base;
        settings.sigma = sig;
        settings.flow_estimator.name = settings.jump_estimator.name = names[e];
        // φ and ψ of impact-msd are affine in ξ: C is the same at every state.
        settings = WithNoiseShapes(model, dt, settings, sig, x0);
        Vec alpha_hat, beta_hat;
        std::unique_ptr<Estimator> flow_owned, jump_owned;
        const Estimator* flow = nullptr;
        const Estimator* jump = nullptr;
        std::optional<Identifier> id;
        int detected = 0;
        if (!oracle) {
          id.emplace(model, dt, settings);
          for (long k = 0; k < y.cols(); ++k) detected += id->Step(y.col(k)).gamma ? 1 : 0;
          alpha_hat = id->alpha_hat();
          beta_hat = id->beta_hat();
          flow = &id->flow_estimator();
          jump = &id->jump_estimator();
        } else {
          RegressionBuilder builder(model);
          const RegressionLayout& fl = builder.flow_layout();
          const RegressionLayout& jl = builder.jump_layout();
          flow_owned = MakeEstimator(settings.flow_estimator, Vec::Zero(Eigen::Index(fl.unknown.size())));
          jump_owned = MakeEstimator(settings.jump_estimator, Vec::Zero(Eigen::Index(jl.unknown.size())));
          Mat phi(Eigen::Index(fl.rows.size()), Eigen::Index(fl.unknown.size()));
          Mat psi(Eigen::Index(jl.rows.size()), Eigen::Index(jl.unknown.size()));
          Vec yf(phi.rows()), yj(psi.rows());
          for (long k = 1; k < y.cols(); ++k) {
            if (traj.j[std::size_t(k)] == traj.j[std::size_t(k - 1)]) {
              builder.Flow(y.col(k - 1), y.col(k), dt, phi, yf);
              flow_owned->Update(phi, yf);
            } else {
              builder.Jump(y.col(k - 1), y.col(k), psi, yj);
              jump_owned->Update(psi, yj);
              ++detected;
            }
          }
          alpha_hat = fl.Assemble(model.alpha(), flow_owned->estimate());
          beta_hat = jl.Assemble(model.beta(), jump_owned->estimate());
          flow = flow_owned.get();
          jump = jump_owned.get();
        }
        const ParameterErrors err = CompareParameters(model, alpha_hat, beta_hat);
        Trial& t = cells[e][std::size_t(trial)];
        t.e_alpha = err.e_alpha;
        t.e_beta = err.e_beta;
        t.a = alpha_hat[1];
        t.b = alpha_hat[2];
        t.lambda = beta_hat[1];
        t.mu = beta_hat[2];
        t.flow_ok = flow->status() == EstimatorStatus::kOk;
        t.jump_ok = jump->status() == EstimatorStatus::kOk;
        t.jumps_detected = detected;
        if (const auto* f = dynamic_cast<const Frisch*>(flow)) {
          t.flow_covered = f->Contains(model.alpha().tail(2));
          if (f->has_box()) t.flow_box_width_a = f->upper()[0] - f->lower()[0];
        }
        if (const auto* f = dynamic_cast<const Frisch*>(jump)) {
          t.jump_covered = f->Contains(model.beta().tail(2));
          if (f->has_box()) t.jump_box_width_lambda = f->upper()[0] - f->lower()[0];
        }
      }
    });
    for (std::size_t e = 0; e < names.size(); ++e) {
      const std::vector<Trial>& c = cells[e];
      const Stat ea = Summarise(c, [](const Trial& t) { return t.e_alpha; });
      const Stat eb = Summarise(c, [](const Trial& t) { return t.e_beta; });
      const Stat a = Summarise(c, [](const Trial& t) { return t.a; });
      const Stat b = Summarise(c, [](const Trial& t) { return t.b; });
      const Stat l = Summarise(c, [](const Trial& t) { return t.lambda; });
      const Stat mu = Summarise(c, [](const Trial& t) { return t.mu; });
      int flow_ok = 0, jump_ok = 0, fcov = 0, jcov = 0;
      bool has_box = false;
      for (const Trial& t : c) {
        flow_ok += t.flow_ok;
        jump_ok += t.jump_ok;
        if (t.flow_covered >= 0) has_box = true;
        fcov += t.flow_covered > 0;
        jcov += t.jump_covered > 0;
      }
      const std::string box = has_box ? fmt::format("{}/{} {}/{}", fcov, trials, jcov, trials) : "-";
      // Paired against rls (same noise in every trial): differences of the errors.
      Stat da{NAN, NAN}, db{NAN, NAN};
      std::string paired = "-";
      if (rls_index < names.size() && rls_index != e) {
        std::vector<Trial> diff(c.size());
        for (std::size_t k = 0; k < c.size(); ++k) {
          diff[k].e_alpha = c[k].e_alpha - cells[rls_index][k].e_alpha;
          diff[k].e_beta = c[k].e_beta - cells[rls_index][k].e_beta;
        }
        da = Summarise(diff, [](const Trial& t) { return t.e_alpha; });
        db = Summarise(diff, [](const Trial& t) { return t.e_beta; });
        paired = fmt::format("{:+.4f} +- {:.4f}, {:+.4f} +- {:.4f}", da.mean, da.ci, db.mean, db.ci);
      }
      std::printf("%-6g %-7s %-22s %-22s %-9.4f %-9.4f %-9.4f %-9.4f %-8s %-18s %s\n", sigma,
                  names[e].c_str(), fmt::format("{:.4f} +- {:.4f}", ea.mean, ea.ci).c_str(),
                  fmt::format("{:.4f} +- {:.4f}", eb.mean, eb.ci).c_str(), a.mean, b.mean, l.mean,
                  mu.mean, fmt::format("{}/{}", flow_ok, jump_ok).c_str(), box.c_str(),
                  paired.c_str());
      if (trial_csv) {
        for (int k = 0; k < trials; ++k) {
          const Trial& t = c[std::size_t(k)];
          trial_csv->TextRow(std::vector<std::string>{
              num(sigma), names[e], std::to_string(k), num(t.e_alpha), num(t.e_beta), num(t.a),
              num(t.b), num(t.lambda), num(t.mu), std::to_string(t.flow_ok),
              std::to_string(t.jump_ok), std::to_string(t.jumps_detected),
              std::to_string(t.flow_covered), std::to_string(t.jump_covered),
              num(t.flow_box_width_a), num(t.jump_box_width_lambda)});
        }
        summary_csv->TextRow(std::vector<std::string>{
            num(sigma), names[e], std::to_string(trials), num(ea.mean), num(ea.ci), num(eb.mean),
            num(eb.ci), num(a.mean), num(a.ci), num(b.mean), num(b.ci), num(l.mean), num(l.ci),
            num(mu.mean), num(mu.ci), std::to_string(flow_ok), std::to_string(jump_ok),
            has_box ? num(double(fcov) / trials) : "", has_box ? num(double(jcov) / trials) : "",
            std::isnan(da.mean) ? "" : num(da.mean), std::isnan(da.ci) ? "" : num(da.ci),
            std::isnan(db.mean) ? "" : num(db.mean), std::isnan(db.ci) ? "" : num(db.ci)});
      }
    }
    std::fflush(stdout);
  }
  if (!out.empty()) {
    trial_csv->Commit();
    summary_csv->Commit();
    std::string command;
    for (int i = 0; i < argc; ++i) command += (i ? " " : "") + std::string(argv[i]);
    const nlohmann::json meta = {
        {"command", command},
        {"system", "impact-msd a=5 b=0.1 lambda=0.99 mu=0, x0=(20,0), 20 s, dt=0.5 ms, 14 jumps"},
        {"labels", labels},
        {"detector", {{"name", "paper"}, {"r", 220.0}, {"tau0", 1e5}}},
        {"seed", seed},
        {"trials", trials},
        {"sigma", sigmas},
        {"estimators", names},
        {"frisch", {{"window", window}, {"jump_window", jump_window}, {"box", frisch_box},
                    {"point", frisch_point}, {"confidence", frisch_confidence}}},
        {"p0", base.flow_estimator.p0},
        {"refactor_every", base.flow_estimator.refactor_every},
        {"noise_shape", "WithNoiseShapes with the true sigma"},
        {"context", BuildContext()},
    };
    std::ofstream(std::filesystem::path(out) / "run.json") << meta.dump(2) << "\n";
    std::printf("wrote %s/{trials,summary}.csv and run.json\n", out.c_str());
  }
  return 0;
}
