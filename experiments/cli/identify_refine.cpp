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
#include "experiments/request/outcome_json.hpp"
#include "core/model/automaton.hpp"
#include "sim/refine/refine.hpp"

namespace hysid::cli {

// The model's α, β are the true values: identify sets them from the same sidecar when it is of this model.
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

namespace {


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

// singular-fisher at the noise: the refined values the data determine, with their standard errors,
// and the unknowns they do not.
void PrintDetermined(const RefineResult& r) {
  const Vec& se = r.determined_standard_errors;
  if (se.size() != static_cast<Eigen::Index>(r.names.size())) return;
  const Vec theta = r.refined.Theta(r.unknowns);
  std::vector<std::string> undetermined;
  std::printf("  the refined point fits the data to the noise; at it the data determine:\n");
  for (std::size_t i = 0; i < r.names.size(); ++i) {
    const auto ii = static_cast<Eigen::Index>(i);
    if (std::isnan(se[ii])) {
      undetermined.push_back(r.names[i]);
    } else {
      std::printf("    %-10s = %-14.10g ± %.4g\n", r.names[i].c_str(), theta[ii], se[ii]);
    }
  }
  std::printf("  and not %s (only a combination of them)\n",
              fmt::format("{}", fmt::join(undetermined, ", ")).c_str());
}

// The refinement's status, the chains and samples it fit, and how the fit was reached (--refine ml).
void PrintRefinement(const Model& model, const SampleData& data, const IdentifyResult& recursive,
                     const RefineStep& step) {
  const RefineResult& r = step.result;
  std::printf("refinement (maximum likelihood, output error): %s%s%s\n", ToString(r.status), r.ok() ? "" : ": ",
              r.reason.c_str());
  if (!r.route.empty()) std::printf("  route: %s\n", r.route.c_str());
  for (const std::string& tried : r.routes_tried) std::printf("  tried: %s\n", tried.c_str());
  for (const OutlierSample& o : step.fit_outliers) {
    const std::string& file =
        o.run < static_cast<int>(data.run_names.size()) ? data.run_names[std::size_t(o.run)] : data.path;
    std::printf(
        "  outlier left out by the fit: %s line %ld, t = %.6g: %s = %.6g, its residual %.3g robust sd "
        "off the first fit, alone there (--keep-outliers keeps it)\n",
        file.c_str(), o.line, o.t, data.state_columns[std::size_t(o.row)].c_str(), o.value, o.sds);
  }
  if (!data.uniform) {
    const std::string each =
        r.gaps_joined > 0 ? fmt::format("as {} trajector{}, the model run through {} gap{}; one initial state per "
                                        "trajectory",
                                        r.chains_used - r.gaps_joined, r.chains_used - r.gaps_joined > 1 ? "ies" : "y",
                                        r.gaps_joined, r.gaps_joined > 1 ? "s" : "")
                          : std::string("one initial state each");
    std::printf(
        "  %ld chains fitted (%s, alpha and beta shared), %ld left out (fewer "
        "than %d samples or a first sample outside C and D); %ld of %ld samples\n",
        r.chains_used, each.c_str(), r.chains_skipped, 2 * model.state_size() + 2, r.samples_used,
        static_cast<long>(data.y.cols()));
    if (!r.span_reason.empty()) std::printf("  %s\n", r.span_reason.c_str());
  } else if (const long span = step.span(); span < data.y.cols()) {
    std::printf("  fitted the first %ld of %ld samples (t <= %.6g): %s\n", span,
                static_cast<long>(data.y.cols()), static_cast<double>(span - 1) * data.dt,
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
    PrintDetermined(r);
  } else if (!r.ok()) {
    std::printf("  the refined estimate is reported: the fit converged, its residual tests refuse it\n");
  }
}

}  // namespace


void AddRefineOptions(CLI::App* cmd, RefineArgs& args) {
  AddSetting(*cmd, "x0_known", args.x0_known);
  AddSetting(*cmd, "x0", args.x0.x0);
  AddSetting(*cmd, "refine", args.refine)
      ->check(CLI::Validator([](std::string& text) { return RefineChoiceProblem(text); }, "{ml,none}"));
  cmd->add_option("--json", args.json,
                  "write everything the report shows as JSON: settings, estimates, standard errors, "
                  "covariance, detections, per-chain counts, truth comparison, the fit's checks "
                  "(docs/outputs.md)");
}

int RefineAndReport(const IdentifyRequest& request, IdentifyOutcome& outcome, const RefineArgs& args,
                    const std::string& trace, const nlohmann::json& selection, bool refined) {
  // The recursive report is out before the refinement, which may take long: a signal that ends hysid
  // then (its handler exits without flushing) keeps it, also when stdout is a file or a pipe.
  if (args.refine == "ml") std::fflush(stdout);
  if (!refined) RunRefinement(request, &outcome);
  const Model& model = outcome.model;
  const SampleData& data = outcome.data;
  const RefineStep& step = outcome.refinement;
  const RefineResult& r = step.result;
  if (args.refine == "ml") PrintRefinement(model, data, outcome.recursive, step);
  PrintEstimates(r, step.truth, step.bound);
  for (const std::string& note : step.notes) std::printf("note: %s\n", note.c_str());
  if (step.bound.ok()) {
    std::printf("  CRLB at the truth (sigma from %s): %s\n",
                std::filesystem::path(data.path).replace_extension(".json").c_str(),
                CrlbMeanErrors(r.unknowns, step.bound, 4).c_str());
  }
  if (args.refine == "ml" && IsAutomaton(model.spec())) PrintFittedEvents(model, outcome.recursive, step.fitted);
  if (!trace.empty()) {
    const std::vector<int>& measured = outcome.partial.measured;
    AppendFitColumns(trace, model.spec(), measured.empty() ? MeasuredIndices(model) : measured, data.y,
                     step.outputs);
    std::printf("wrote %s: the fitted model's columns added (fit_, sd_, residual_, recursive_)\n", trace.c_str());
  }
  if (!args.json.empty()) {
    nlohmann::json j = OutcomeJson(outcome);
    if (!selection.is_null()) j["selection"] = selection;
    WriteFileAtomically(args.json, j.dump(2) + "\n");
    std::printf("wrote %s\n", args.json.c_str());
  }
  std::printf("status: %s\n", args.refine == "none" ? "recursive (no refinement)" : ToString(r.status));
  return args.refine == "ml" && !r.ok() ? 1 : 0;
}

}  // namespace hysid::cli
