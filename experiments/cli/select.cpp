// hysid identify with candidate terms: select, bootstrap, write the chosen model.
#include "experiments/cli/select.hpp"

#include <chrono>
#include <cstdio>
#include <map>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "core/io/files.hpp"
#include "core/model_file/chosen.hpp"
#include "core/model_file/model_file.hpp"
#include "experiments/cli/cli.hpp"

namespace hysid::cli {
namespace {

const CandidateTerm* CandidateOf(const ModelSpec& spec, int alpha) {
  for (const CandidateTerm& c : spec.candidates)
    if (c.alpha == alpha) return &c;
  return nullptr;
}

// "v' += v_2*(x)": a candidate as the report names it.
std::string TermText(const ModelSpec& spec, int alpha) {
  const CandidateTerm* c = CandidateOf(spec, alpha);
  return fmt::format("{}' term {}", spec.state_names[std::size_t(c->row)], c->term);
}

}  // namespace

void PrintSelection(const Model& model, const SelectStep& step) {
  const ModelSpec& spec = model.spec();
  const Selection& s = step.selection;
  std::printf("selection: %zu candidate terms, %d flow segments (%s), %ld integral "
              "rows; %d supports from thresholded least squares and backward elimination, chosen by "
              "cross-validation over the segments (%.2f s)\n",
              spec.candidates.size(), step.segments,
              step.round == 1 ? "the detections of the pass with every candidate"
                              : fmt::format("the detections of the chosen model, round {}", step.round).c_str(),
              s.rows, s.supports, step.seconds);
  std::printf("  chosen: %s (held-out mean square %.6g; BIC %.2f, the least BIC of another support %s)\n",
              step.kept.empty() ? "no candidate" : fmt::format("{}", fmt::join(step.kept, ", ")).c_str(), s.cv, s.bic,
              std::isfinite(s.runner_up_bic) ? fmt::format("{:+.2f}", s.runner_up_bic - s.bic).c_str() : "none");
  for (std::size_t j = 0; j < step.columns.size(); ++j) {
    if (!step.selectable[j]) continue;
    std::string line = fmt::format("  {:<8} {:<22} {:<6}", step.names[j], step.terms[j], s.chosen[j] ? "chosen" : "-");
    if (s.chosen[j]) line += fmt::format(" {:<14.8g}", s.estimate[Eigen::Index(j)]);
    else line += fmt::format(" {:<14}", "");
    if (step.bootstrap.draws > 0)
      line += fmt::format(" chosen in {:5.1f}% of bootstrap draws", 100.0 * step.bootstrap.frequency[Eigen::Index(j)]);
    std::printf("%s\n", line.c_str());
  }
  if (step.bootstrap.draws > 0) {
    std::printf("  bootstrap: %d draws of the flow segments with replacement; the cross-validated support "
                "exactly in %d\n",
                step.bootstrap.draws, step.bootstrap.support_matches);
  }
  for (const int j : step.unstable) {
    std::printf("  dropped as unstable: %s (chosen by cross-validation, by %.1f%% of the bootstrap draws, "
                "fewer than %.0f%%)\n",
                step.names[std::size_t(j)].c_str(), 100.0 * step.bootstrap.frequency[Eigen::Index(j)],
                100.0 * SelectOptions{}.min_share);
  }
}

namespace {

// The chosen model's text: the kept candidates as α entries with `values`.
std::string ChosenText(const SelectStep& step, const std::map<std::string, double>& values, const std::string& note) {
  return ChosenModelText(step.text, step.file, step.kept, values,
                         {fmt::format("chosen by hysid identify from {} ({})", step.file, note)});
}

}  // namespace

void AddSelectOptions(CLI::App& cmd, SelectArgs& args) {
  cmd.add_option("--chosen-model", args.chosen_model,
                 "a model file with candidate terms: write the chosen model (the chosen terms as plain alpha "
                 "entries, the estimates as values) to this file");
  cmd.add_option("--select-bootstrap", args.bootstrap,
                 "a model file with candidate terms: bootstrap draws of the flow segments for how often each "
                 "term is chosen; a term chosen by fewer than half of them is dropped (0: no bootstrap, "
                 "nothing dropped)")
      ->capture_default_str();
  cmd.add_option("--select-seed", args.seed, "seed of the selection's bootstrap")->capture_default_str()
      ->transform(NonNegativeInteger);
}

void CheckSelectArgs(const SelectArgs& args, const Model& model) {
  if (!args.chosen_model.empty() && model.spec().candidates.empty()) {
    BadFlag(fmt::format("--chosen-model: model '{}' has no candidate terms ([flow] candidates) to choose from",
                        model.name()));
  }
  if (args.bootstrap < 0 || args.bootstrap > 100000)
    BadFlag(fmt::format("--select-bootstrap = {}: must be in [0, 100000]", args.bootstrap));
}

SelectStep SelectCandidates(const Model& model, const std::string& file, const SampleData& data,
                            const IdentifyResult& detected, const SelectArgs& args, bool bootstrap) {
  const auto start = std::chrono::steady_clock::now();
  SelectStep step;
  step.file = file;
  step.text = ReadWholeFile(file, "model file");
  const FlowSamples samples{.y = &data.y,
                            .gamma = &detected.gamma,
                            .dt = data.dt,
                            .times = data.uniform ? nullptr : &data.t,
                            .chain_start = data.uniform ? nullptr : &data.chain_start,
                            .inputs = data.u.rows() > 0 ? &data.u : nullptr};
  const FlowSums sums = SumFlowSegments(model, samples);
  step.columns = sums.columns;
  step.segments = static_cast<int>(sums.segments.size());
  for (int a : sums.columns) {
    step.selectable.push_back(CandidateOf(model.spec(), a) != nullptr);
    step.names.push_back(model.spec().alpha[std::size_t(a)].name);
    const CandidateTerm* c = CandidateOf(model.spec(), a);
    step.terms.push_back(c ? TermText(model.spec(), a) : "");
    step.rows.push_back(c ? model.spec().state_names[std::size_t(c->row)] : "");
    step.raw_terms.push_back(c ? c->term : "");
  }
  step.selection = SelectTerms(sums, step.selectable, SelectOptions{});
  if (!step.selection.ok) throw RunFailed(fmt::format("identify: no terms selected: {}", step.selection.reason));
  if (bootstrap && args.bootstrap > 0) {
    step.bootstrap = BootstrapSelection(sums, step.selectable, SelectOptions{}, args.bootstrap, args.seed,
                                        step.selection.chosen);
    Selection stable = KeepStable(sums, step.selectable, step.selection, step.bootstrap, SelectOptions{});
    for (std::size_t j = 0; j < step.columns.size(); ++j) {
      if (step.selection.chosen[j] && !stable.chosen[j]) step.unstable.push_back(static_cast<int>(j));
    }
    step.selection = std::move(stable);
  }
  std::map<std::string, double> values;
  for (std::size_t j = 0; j < step.columns.size(); ++j) {
    const std::string& name = model.spec().alpha[std::size_t(step.columns[j])].name;
    if (step.selectable[j] && step.selection.chosen[j]) step.kept.push_back(name);
    if (step.selection.chosen[j]) values[name] = step.selection.estimate[Eigen::Index(j)];
  }
  // Not required to reach its guards on the default trajectory (ParseModelFile, not ParseModelText):
  // with the least-squares values of a first round it may not.
  step.chosen = ParseModelFile(ChosenText(step, values, "the selection's least-squares values"), file + " (chosen)").model;
  step.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return step;
}

namespace {

std::vector<std::string> Names(const SelectStep& step, const std::vector<int>& columns) {
  std::vector<std::string> out;
  for (const int j : columns) out.push_back(step.names[std::size_t(j)]);
  return out;
}

}  // namespace

nlohmann::json SelectionJson(const SelectStep& step) {
  nlohmann::json terms = nlohmann::json::array();
  for (std::size_t j = 0; j < step.columns.size(); ++j) {
    if (!step.selectable[j]) continue;
    terms.push_back({{"name", step.names[j]},
                     {"row", step.rows[j]},
                     {"term", step.raw_terms[j]},
                     {"chosen", bool(step.selection.chosen[j])},
                     {"estimate", step.selection.estimate[Eigen::Index(j)]},
                     {"bootstrap_frequency", step.bootstrap.draws > 0
                                                 ? nlohmann::json(step.bootstrap.frequency[Eigen::Index(j)])
                                                 : nlohmann::json()}});
  }
  return {{"terms", terms},
          {"chosen", step.kept},
          {"bic", step.selection.bic},
          {"runner_up_bic", std::isfinite(step.selection.runner_up_bic) ? nlohmann::json(step.selection.runner_up_bic)
                                                                       : nlohmann::json()},
          {"rows", step.selection.rows},
          {"segments", step.segments},
          {"supports", step.selection.supports},
          {"bootstrap_draws", step.bootstrap.draws},
          {"bootstrap_support_matches", step.bootstrap.support_matches},
          {"unstable", Names(step, step.unstable)},
          {"seconds", step.seconds}};
}

void FinishSelection(const SelectStep& step, const Model& chosen, const IdentifyResult& recursive,
                     const RefineResult* refined, const SelectArgs& args) {
  const ModelSpec& spec = chosen.spec();
  const bool fitted = refined != nullptr && refined->reported;
  const Vec alpha = fitted ? refined->estimate.alpha : recursive.alpha_hat;
  const Vec beta = fitted ? refined->estimate.beta : recursive.beta_hat;
  std::map<std::string, double> values;
  for (std::size_t i = 0; i < spec.alpha.size(); ++i)
    if (!spec.alpha[i].known) values[spec.alpha[i].name] = alpha[Eigen::Index(i)];
  for (std::size_t i = 0; i < spec.beta.size(); ++i)
    if (!spec.beta[i].known) values[spec.beta[i].name] = beta[Eigen::Index(i)];
  if (fitted && refined->estimate.gamma.size() == Eigen::Index(spec.guard_params.size())) {
    for (std::size_t i = 0; i < spec.guard_params.size(); ++i)
      if (!spec.guard_params[i].known) values[spec.guard_params[i].name] = refined->estimate.gamma[Eigen::Index(i)];
  }
  std::printf("chosen terms (%s estimates%s):\n", fitted ? "refined" : "recursive",
              step.bootstrap.draws > 0 ? ", how often the bootstrap chose each" : "");
  for (std::size_t j = 0; j < step.columns.size(); ++j) {
    if (!step.selectable[j] || !step.selection.chosen[j]) continue;
    const std::string& name = step.names[j];
    double se = std::nan("");
    for (std::size_t k = 0; fitted && k < refined->names.size(); ++k) {
      if (refined->names[k] == name && refined->standard_errors.size() > Eigen::Index(k))
        se = refined->standard_errors[Eigen::Index(k)];
    }
    std::string line = fmt::format("  {:<8} {:<22} = {:<14.10g}", name, step.terms[j], values.at(name));
    line += std::isfinite(se) ? fmt::format(" ± {:<10.4g}", se) : fmt::format(" {:<12}", "");
    if (step.bootstrap.draws > 0)
      line += fmt::format(" chosen in {:.1f}%", 100.0 * step.bootstrap.frequency[Eigen::Index(j)]);
    std::printf("%s\n", line.c_str());
  }
  if (args.chosen_model.empty()) return;
  WriteFileAtomically(args.chosen_model,
                      ChosenText(step, values, fitted ? "refined estimates" : "recursive estimates"));
  std::printf("wrote %s\n", args.chosen_model.c_str());
}

}  // namespace hysid::cli
