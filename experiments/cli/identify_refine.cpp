// hysid identify, after the recursive run: the maximum-likelihood refinement (sim/refine), each
// estimate with its standard error, the CRLB ratio when the truth is known, the status, and --json.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "core/io/files.hpp"
#include "experiments/cli/cli.hpp"
#include "experiments/cli/identify_events.hpp"
#include "experiments/cli/identify_output.hpp"
#include "sim/input_signal.hpp"
#include "core/model/automaton.hpp"
#include "sim/refine/refine.hpp"
#include "sim/refine/solver_progress.hpp"

namespace hysid::cli {
namespace {

// The truth of data written by `hysid simulate`: x0 and σ from its sidecar FILE.json (the model's
// α, β are the true values: identify sets them from the same sidecar when it is of this model).
// Empty when there is no such sidecar.
Truth ReadTruth(const std::string& data_path, int n) {
  std::ifstream in(std::filesystem::path(data_path).replace_extension(".json"));
  if (!in) return {};
  const nlohmann::json meta = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (!meta.is_object() || !meta.contains("command") || meta["command"] != "simulate") return {};
  auto vec = [&](const char* key) {
    if (!meta.contains(key) || !meta[key].is_array() || static_cast<int>(meta[key].size()) != n) return Vec();
    Vec v(n);
    for (int i = 0; i < n; ++i) {
      if (!meta[key][static_cast<std::size_t>(i)].is_number()) return Vec();
      v[i] = meta[key][static_cast<std::size_t>(i)].get<double>();
    }
    return v;
  };
  return {vec("x0"), vec("sigma")};
}

// The CRLB at the truth when the data carry it (sidecar x0 and σ > 0, same grid) over at least two
// samples (a refinement that fitted fewer has no span to bound), else not ok; with the data's inputs
// (their times from the first sample's) for a model with inputs.
Crlb TruthBound(const Model& model, const Truth& truth, long samples, const SampleData& data,
                const std::vector<int>& measured, const std::vector<int>& known) {
  const double dt = data.dt;
  if (truth.x0.size() == 0 || truth.sigma.size() == 0 || !(truth.sigma(measured).array() > 0.0).all() ||
      samples < 2) {
    Crlb none;
    none.status = CrlbStatus::kSimulationFailed;
    none.message = samples < 2 ? "fewer than 2 samples fitted" : "no truth";
    return none;
  }
  const SampleGrid grid{.t_end = static_cast<double>(samples - 1) * dt, .dt = dt};
  InputSignal inputs;
  if (data.u.rows() > 0) {
    for (double t : data.t) inputs.times.push_back(t - data.t.front());
    inputs.values = data.u;
  }
  const bool all = static_cast<int>(measured.size()) == model.state_size();
  const Unknowns unknowns = Unknowns::Of(model);
  // The known components of ξ0 held, as the refinement holds them.
  return HoldKnownX0(
      ComputeCrlb(model, truth.x0, grid, all ? truth.sigma : Vec(truth.sigma(measured)), unknowns, {},
                  all ? std::vector<int>{} : measured, inputs.empty() ? nullptr : &inputs),
      unknowns, known, model.state_size());
}

void PrintEstimates(const RefineResult& r, const HybridParameters& truth_params, const Crlb& bound) {
  const Vec theta = r.estimate.Theta(r.unknowns);
  const bool truth = bound.ok();
  const bool se = r.standard_errors.size() == static_cast<Eigen::Index>(r.names.size());
  const Vec true_theta = truth ? truth_params.Theta(r.unknowns) : Vec();
  for (std::size_t i = 0; i < r.names.size(); ++i) {
    const auto ii = static_cast<Eigen::Index>(i);
    std::string line = fmt::format("  {:<10} = {:<14.10g}", r.names[i], theta[ii]);
    if (se && r.ok() && r.standard_errors[ii] == 0.0) {  // held (--x0-known)
      std::printf("%s (known)\n", line.c_str());
      continue;
    }
    line += se ? fmt::format(" ± {:<10.4g}", r.standard_errors[ii]) : fmt::format(" {:<12}", "(no se)");
    if (truth && !(bound.sd[ii] > 0.0)) {  // held in the bound (--x0-known): it has no CRLB sd
      line += fmt::format("  truth {:.10g}: error {:.3g} (no CRLB: known, held in the bound)", true_theta[ii],
                          theta[ii] - true_theta[ii]);
    } else if (truth) {
      line += fmt::format("  truth {:.10g}: error {:.3g} = {:.2f} CRLB sd", true_theta[ii],
                          theta[ii] - true_theta[ii], std::abs(theta[ii] - true_theta[ii]) / bound.sd[ii]);
      if (se) line += fmt::format(", se/CRLB sd {:.3f}", r.standard_errors[ii] / bound.sd[ii]);
    }
    std::printf("%s\n", line.c_str());
  }
}

// The checks a fit passes to be ok: each check's value and its limits (RefineOptions).
nlohmann::json ChecksJson(const RefineResult& r, const RefineOptions& options) {
  return {{"residual_rms",
           {{"value", r.normalized_rms},
            {"test_size", options.residual_test_size / 2},
            {"high", r.sigma_estimated ? nlohmann::json(options.rms_high) : nlohmann::json()}}},
          {"lag1", {{"value", r.lag1}, {"test_size", options.residual_test_size / 2}}},
          {"jump_count", {{"model", r.model_jumps}, {"detected", r.detected_jumps}}},
          {"iterations", {{"value", r.iterations}, {"limit", options.max_iterations}}},
          {"initial_cost", r.initial_cost},
          {"final_cost", r.final_cost}};
}

// The estimates against the truth in units of the CRLB (when the bound is known), as printed.
nlohmann::json CrlbJson(const RefineResult& r, const HybridParameters& truth_params, const Crlb& bound) {
  if (!bound.ok()) return nullptr;
  const Vec theta = r.estimate.Theta(r.unknowns), truth = truth_params.Theta(r.unknowns);
  const Vec error = theta - truth;
  const bool se = r.standard_errors.size() == static_cast<Eigen::Index>(r.names.size());
  auto vec = [](const Vec& v) { return std::vector<double>(v.data(), v.data() + v.size()); };
  return {
      {"sd", vec(bound.sd)},
      {"truth", vec(truth)},
      {"error", vec(error)},
      {"error_in_sd", vec(error.cwiseAbs().cwiseQuotient(bound.sd))},
      {"se_over_sd", se ? nlohmann::json(vec(r.standard_errors.cwiseQuotient(bound.sd))) : nlohmann::json()},
      {"mean_e_alpha", bound.mean_e_alpha},
      {"mean_e_beta", bound.mean_e_beta}};
}

// The refinement's part of --json, added to the recursive run's `report` (RecursiveJson).
nlohmann::json ToJson(nlohmann::json j, const RefineResult& r, const IdentifyResult& recursive,
                      const std::string& refine, const RefineOptions& options) {
  auto vec = [](const Vec& v) { return std::vector<double>(v.data(), v.data() + v.size()); };
  j["refine"] = refine;
  j["status"] = refine == "none" ? "recursive" : ToString(r.status);
  j["reason"] = r.reason;
  j["route"] = r.route;
  j["routes_tried"] = r.routes_tried;
  j["reported"] = refine != "none" && r.reported;
  j["names"] = r.names;
  j["estimate"] = vec(r.estimate.Theta(r.unknowns));
  j["recursive_estimate"] = vec(r.start.Theta(r.unknowns));
  j["alpha"] = vec(r.estimate.alpha);
  j["beta"] = vec(r.estimate.beta);
  j["gamma"] = vec(r.estimate.gamma);
  j["standard_errors"] = vec(r.standard_errors);
  nlohmann::json cov = nlohmann::json::array();
  for (Eigen::Index i = 0; i < r.covariance.rows(); ++i) cov.push_back(vec(r.covariance.row(i).transpose()));
  j["covariance"] = cov;
  j["sigma"] = vec(r.sigma);
  j["sigma_estimated"] = r.sigma_estimated;
  j["normalized_rms"] = r.normalized_rms;
  j["lag1"] = r.lag1;
  j["iterations"] = r.iterations;
  if (refine != "none") j["checks"] = ChecksJson(r, options);
  j["detector"] = {{"jumps_detected", recursive.jumps_detected},
                   {"flow_estimator", ToString(recursive.flow_status)},
                   {"flow_estimator_reason", recursive.flow_reason},
                   {"jump_estimator", ToString(recursive.jump_status)},
                   {"jump_estimator_reason", recursive.jump_reason}};
  if (recursive.safe_start && refine != "none") {
    j["start"] = {{"estimator", "rls"},
                  {"reason", recursive.safe_start_reason},
                  {"jumps_detected", recursive.safe_start->jumps_detected}};
  }
  j["model_jumps"] = r.model_jumps;
  j["samples_used"] = r.samples_used;
  j["span_reason"] = r.span_reason;
  j["start_repair"] = r.start_repair;
  j["mended"] = r.mended;
  if (!r.chain_x0.empty()) {
    nlohmann::json x0 = nlohmann::json::array();
    for (const Vec& v : r.chain_x0) x0.push_back(v.size() ? nlohmann::json(vec(v)) : nlohmann::json());
    j["chain_x0"] = x0;
    j["chain_samples_used"] = r.chain_samples_used;
    j["chain_span_reason"] = r.chain_span_reason;
    j["chains_used"] = r.chains_used;
    j["chains_skipped"] = r.chains_skipped;
  }
  return j;
}

// From RefinementStart(recursive): the recursive result itself, or its rls re-run when the α
// estimator was not ok.
RefineResult RunRefinement(const Model& model, const SampleData& data, const IdentifyResult& given,
                           const RefineOptions& options) {
  const IdentifyResult& recursive = RefinementStart(given);
  std::vector<RefineChain> chains = SplitChains(data.t, data.y, data.chain_start, recursive.gamma, data.u);
  AssignChainMaps(data.chain_start, given, &chains);
  return Refine(model, chains, recursive.alpha_hat, recursive.beta_hat, options);
}

// The refinement's status, the chains and samples it fit, and how the fit was reached (--refine ml).
void PrintRefinement(const Model& model, const SampleData& data, const IdentifyResult& recursive,
                     const RefineResult& r) {
  std::printf("refinement (maximum likelihood, output error): %s%s%s\n", ToString(r.status), r.ok() ? "" : ": ",
              r.reason.c_str());
  if (!r.route.empty()) std::printf("  route: %s\n", r.route.c_str());
  for (const std::string& tried : r.routes_tried) std::printf("  tried: %s\n", tried.c_str());
  if (!data.uniform) {
    std::printf(
        "  %ld chains fitted (one initial state each, alpha and beta shared), %ld left out (fewer "
        "than %d samples or a first sample outside C and D); %ld of %ld samples\n",
        r.chains_used, r.chains_skipped, 2 * model.state_size() + 2, r.samples_used,
        static_cast<long>(data.y.cols()));
    if (!r.span_reason.empty()) std::printf("  %s\n", r.span_reason.c_str());
  } else if (r.samples_used < data.y.cols()) {
    std::printf("  fitted the first %ld of %ld samples (t <= %.6g): %s\n", r.samples_used,
                static_cast<long>(data.y.cols()), static_cast<double>(r.samples_used - 1) * data.dt,
                r.span_reason.c_str());
  }
  if (!r.mended.empty()) std::printf("  mended or reached by: %s\n", r.mended.c_str());
  if (recursive.safe_start) std::printf("  %s\n", recursive.safe_start_reason.c_str());
  if (!r.start_repair.empty()) std::printf("  from a repaired start (%s)\n", r.start_repair.c_str());
  if (r.reported) {
    std::printf("  %d iterations, sigma %s (%s), normalised residual RMS %.4g, lag-1 autocorrelation %.3g\n",
                r.iterations, r.sigma_estimated ? "from the residuals" : "as given",
                fmt::format("{:.4g}", fmt::join(r.sigma, ", ")).c_str(), r.normalized_rms, r.lag1);
  }
  if (!r.reported) {
    std::printf("  the recursive estimate is kept\n");
  } else if (!r.ok()) {
    std::printf("  the refined estimate is reported: the fit converged, its residual tests refuse it\n");
  }
}

// The context of the data's first sample: its time and inputs (C and D of a model with inputs read u).
Context FirstSample(const SampleData& data) {
  return {.t = data.t.front(), .u = data.u.rows() > 0 ? data.u.col(0).data() : nullptr};
}

}  // namespace

void CheckRefineArgs(const RefineArgs& args, const Model& model, const SampleData& data) {
  const std::vector<int> known = X0KnownFlag(args.x0_known, model);
  if (known.empty() && !args.x0.x0.empty()) BadFlag("--x0: the known initial state's values; give --x0-known too");
  if (known.empty()) return;
  if (args.refine != "ml") BadFlag("--x0-known: acts on the refinement; --refine none has none");
  if (data.chains() != 1) {
    BadFlag(fmt::format("--x0-known: the data have {} chains (runs, gaps or missing rows); a known initial state "
                        "is one chain's",
                        data.chains()));
  }
  InitialStateFlag(args.x0, model, FirstSample(data));  // its size and C ∪ D
}

void AddRefineOptions(CLI::App* cmd, RefineArgs& args) {
  AddX0KnownOption(*cmd, args.x0_known);
  AddNumberList(*cmd, "--x0", args.x0.x0,
                "with --x0-known: the initial state, comma-separated, one value per state (the known "
                "components are held at theirs; default: the model's)");
  cmd->add_option("--refine", args.refine,
                  "ml: maximum-likelihood output-error refinement of the recursive estimate (with "
                  "standard errors and a fit status; exit 1 when the fit is not ok), none: the "
                  "recursive estimate alone")
      ->check(CLI::Validator([](std::string& text) { return RefineChoiceProblem(text); }, "{ml,none}"))
      ->capture_default_str();
  cmd->add_option("--json", args.json,
                  "write everything the report shows as JSON: settings, estimates, standard errors, "
                  "covariance, detections, per-chain counts, truth comparison, the fit's checks "
                  "(docs/outputs.md)");
}

namespace {

// The notes on the unknown α, β and guard parameters of `e` outside the model's bounds (a model file's
// `bounds`, --param-bound): only the refinement applies bounds, so such an estimate is the recursive one.
std::vector<std::string> BoundNotes(const Model& model, const HybridParameters& e) {
  std::vector<std::string> notes;
  const ModelSpec& spec = model.spec();
  for (const auto& [params, values] : {std::pair{&spec.alpha, &e.alpha}, std::pair{&spec.beta, &e.beta},
                                       std::pair{&spec.guard_params, &e.gamma}}) {
    for (std::size_t i = 0; i < params->size() && static_cast<Eigen::Index>(i) < values->size(); ++i) {
      const Parameter& p = (*params)[i];
      const double estimate = (*values)[static_cast<Eigen::Index>(i)];
      if (p.known || !(estimate < p.lower || estimate > p.upper)) continue;
      notes.push_back(fmt::format("{} = {:.6g} lies outside its bounds [{:g}, {:g}]: this is the recursive "
                                  "estimate, which applies no bounds (only the refinement does)",
                                  p.name, estimate, p.lower, p.upper));
    }
  }
  return notes;
}

}  // namespace

RefineStep RunRefineStep(const Model& model, const SampleData& data, const IdentifyResult& recursive,
                         const Vec& sigma, const RefineArgs& args, const PartialOutputs& partial,
                         const Truth& truth, const std::atomic<bool>* stop, StageProgress* progress) {
  RefineStep s;
  s.options.stop = stop;
  s.known = X0KnownFlag(args.x0_known, model);
  RefineResult& r = s.result;
  s.options.sigma = sigma;
  if (!partial.reconstructed.empty()) s.options.measured = partial.measured;
  s.options.x0_known = s.known;
  if (!s.known.empty()) s.options.x0 = InitialStateFlag(args.x0, model, FirstSample(data));
  if (args.refine == "ml") {
    if (progress != nullptr) progress->Stage("refinement");
    const ScopedSolverProgress watch([progress](int fit, int iteration, double cost) {
      if (progress != nullptr) progress->Iteration(fit, iteration, cost);
    });
    r = RunRefinement(model, data, recursive, s.options);
  } else {
    r.unknowns = Unknowns::Of(model);
    r.names = r.unknowns.Names(model);
    r.start = r.estimate =
        HybridParameters{recursive.alpha_hat, recursive.beta_hat, data.y.col(0), model.gamma()};
  }
  const long used = args.refine == "ml" ? r.samples_used : data.y.cols();
  s.bound = TruthBound(model, truth, used, data, partial.measured.empty() ? MeasuredIndices(model) : partial.measured,
                       s.known);
  s.truth = HybridParameters::Of(model, truth.x0);
  if (progress != nullptr) progress->Stage("the fitted model over the record");
  if (args.refine == "ml" && IsAutomaton(model.spec())) s.fitted = FittedEventsOf(model, data, recursive, r);
  s.outputs = RunFittedModel(model, data.t, data.y, data.chain_start, data.u, recursive, r);
  if (progress != nullptr) progress->Clear();
  s.notes = UnitNotes(model, r.estimate);
  for (std::string& note : BoundNotes(model, r.estimate)) s.notes.push_back(std::move(note));
  return s;
}

std::vector<std::string> UnitNotes(const Model& model, const HybridParameters& e) {
  std::vector<std::string> notes;
  const ModelSpec& spec = model.spec();
  for (const auto& [params, values] : {std::pair{&spec.alpha, &e.alpha}, std::pair{&spec.beta, &e.beta},
                                       std::pair{&spec.guard_params, &e.gamma}}) {
    for (std::size_t i = 0; i < params->size() && static_cast<Eigen::Index>(i) < values->size(); ++i) {
      const Parameter& p = (*params)[i];
      const double estimate = (*values)[static_cast<Eigen::Index>(i)];
      if (p.known || p.value == 0.0 || estimate == 0.0 || !std::isfinite(estimate)) continue;
      const double ratio = std::abs(estimate / p.value);
      if (ratio < kUnitsFactor && ratio > 1.0 / kUnitsFactor) continue;
      notes.push_back(
          fmt::format("{} = {:.4g} is {:.2g} times {} than its start value {:g} (the model's): check "
                      "the units of the data and of the model's values",
                      p.name, estimate, ratio >= 1.0 ? ratio : 1.0 / ratio,
                      ratio >= 1.0 ? "larger" : "smaller", p.value));
    }
  }
  return notes;
}

nlohmann::json RefineJson(const Model& model, const SampleData& data, const IdentifyResult& recursive,
                          const RefineArgs& args, const nlohmann::json& report, const PartialOutputs& partial,
                          const RefineStep& step) {
  const RefineResult& r = step.result;
  nlohmann::json j = ToJson(report, r, recursive, args.refine, step.options);
  j["samples"] = data.y.cols();
  j["min_chain_samples"] = 2 * model.state_size() + 2;
  j["fit_t_end"] = data.uniform && r.samples_used > 0
                       ? nlohmann::json(static_cast<double>(r.samples_used - 1) * data.dt)
                       : nlohmann::json();
  if (args.refine == "ml" && IsAutomaton(model.spec()) && j.contains("automaton")) {
    AddFittedEventsJson(step.fitted, &j["automaton"]);
  }
  if (step.bound.ok())
    j["crlb_sd"] = std::vector<double>(step.bound.sd.data(), step.bound.sd.data() + step.bound.sd.size());
  j["crlb"] = CrlbJson(r, step.truth, step.bound);
  j["fitted_events"] = FittedEventsJson(model.spec(), data.t, step.outputs);
  // The states the data held, those reconstructed as the recursive pass's start, and x0 held.
  auto named = [&](const std::vector<int>& indices) {
    std::vector<std::string> out;
    for (const int i : indices) out.push_back(model.spec().state_names[static_cast<std::size_t>(i)]);
    return out;
  };
  j["measured"] = named(partial.measured.empty() ? MeasuredIndices(model) : partial.measured);
  j["reconstructed"] = named(partial.reconstructed);
  if (!partial.reconstruction.empty()) j["reconstruction"] = partial.reconstruction;
  j["x0_known"] = named(step.known);
  j["notes"] = step.notes;
  return j;
}

int RefineAndReport(const Model& model, const SampleData& data, const IdentifyResult& recursive,
                    const Vec& sigma, const RefineArgs& args, const nlohmann::json& report,
                    const PartialOutputs& partial, const std::string& trace, StageProgress* progress,
                    RefineResult* refined) {
  // The recursive report is out before the refinement, which may take long: a signal that ends hysid
  // then (its handler exits without flushing) keeps it, also when stdout is a file or a pipe.
  if (args.refine == "ml") std::fflush(stdout);
  const Truth truth = data.j && data.uniform ? ReadTruth(data.path, model.state_size()) : Truth{};
  const RefineStep step = RunRefineStep(model, data, recursive, sigma, args, partial, truth, nullptr, progress);
  if (refined != nullptr) *refined = step.result;
  const RefineResult& r = step.result;
  if (args.refine == "ml") PrintRefinement(model, data, recursive, r);
  PrintEstimates(r, step.truth, step.bound);
  for (const std::string& note : step.notes) std::printf("note: %s\n", note.c_str());
  if (step.bound.ok()) {
    std::printf("  CRLB at the truth (sigma from %s): %s\n",
                std::filesystem::path(data.path).replace_extension(".json").c_str(),
                CrlbMeanErrors(r.unknowns, step.bound, 4).c_str());
  }
  if (args.refine == "ml" && IsAutomaton(model.spec())) PrintFittedEvents(model, recursive, step.fitted);
  if (!trace.empty()) {
    AppendFitColumns(trace, model.spec(), partial.measured.empty() ? MeasuredIndices(model) : partial.measured,
                     data.y, step.outputs);
    std::printf("wrote %s: the fitted model's columns added (fit_, sd_, residual_, recursive_)\n", trace.c_str());
  }
  if (!args.json.empty()) {
    const nlohmann::json j = RefineJson(model, data, recursive, args, report, partial, step);
    WriteFileAtomically(args.json, j.dump(2) + "\n");
    std::printf("wrote %s\n", args.json.c_str());
  }
  std::printf("status: %s\n", args.refine == "none" ? "recursive (no refinement)" : ToString(r.status));
  return args.refine == "ml" && !r.ok() ? 1 : 0;
}

}  // namespace hysid::cli
