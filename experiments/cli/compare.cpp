// hysid compare: candidate model files fitted on the same data and ranked by AIC, BIC and the error
// of their forecast of held-out samples (experiments/request/compare_fit.hpp says how each is computed).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "core/io/files.hpp"
#include "sim/model_check/model_check.hpp"
#include "experiments/cli/cli.hpp"
#include "experiments/request/compare_fit.hpp"

namespace hysid::cli {
namespace {

struct CompareArgs {
  std::vector<std::string> models;  // the candidate model files
  std::vector<std::string> data;    // --data, repeatable
  double holdout = 0.25;            // --holdout
  std::string holdout_by = "tail";  // --holdout-by
  double chain_head = 0.1;          // --chain-head
  std::string json, csv;            // --json, --csv
};

void CheckCompareOutputs(const CompareArgs& args) {
  InputFiles inputs;
  for (const std::string& d : args.data) inputs.Add("--data", d);
  for (const std::string& m : args.models) inputs.Add("model file", m);
  std::vector<std::pair<std::string, std::filesystem::path>> outputs;
  if (!args.json.empty()) outputs.emplace_back("--json", args.json);
  if (!args.csv.empty()) outputs.emplace_back("--csv", args.csv);
  CheckOutputPaths(outputs, inputs);
}

std::string Number(double v, const char* format = "{:.1f}") {
  return std::isfinite(v) ? fmt::format(fmt::runtime(format), v) : "-";
}

// The status column: the refinement's status, and a mark when the criteria's assumptions fail.
std::string StatusText(const Candidate& c) {
  std::string s = c.fit.status;
  if (c.ranked && c.fit.status != "ok") s += " *";
  if (c.ranked && c.fit.samples_fitted < c.fit.samples) s += " †";
  return s;
}

std::string HoldoutText(const Candidate& c) {
  if (!c.holdout.done) return c.holdout.status == "none" ? "-" : "no forecast";
  std::vector<std::string> parts;
  for (Eigen::Index j = 0; j < c.holdout.rmse.size(); ++j) parts.push_back(fmt::format("{:.4g}", c.holdout.rmse[j]));
  return fmt::format("{} (#{})", fmt::join(parts, ", "), c.holdout_rank);
}

// Ranked by BIC first, then the others in the order given.
std::vector<const Candidate*> TableOrder(const std::vector<Candidate>& candidates) {
  std::vector<const Candidate*> order;
  for (const Candidate& c : candidates)
    if (c.ranked) order.push_back(&c);
  std::stable_sort(order.begin(), order.end(), [](const Candidate* a, const Candidate* b) { return a->bic_rank < b->bic_rank; });
  for (const Candidate& c : candidates)
    if (!c.ranked) order.push_back(&c);
  return order;
}

void PrintTable(const std::vector<Candidate>& candidates, const std::vector<std::string>& outputs) {
  int width = 5;
  for (const Candidate& c : candidates) width = std::max(width, static_cast<int>(c.name.size()));
  std::printf("%-4s %-*s %-24s %3s %12s %12s %8s %6s %12s %8s %6s  %s\n", "rank", width, "model", "status", "k", "log L",
              "AIC", "dAIC", "w_AIC", "BIC", "dBIC", "w_BIC",
              fmt::format("held-out RMSE ({})", fmt::join(outputs, ", ")).c_str());
  for (const Candidate* c : TableOrder(candidates)) {
    const std::string rank = c->ranked ? std::to_string(c->bic_rank) : "-";
    std::printf("%-4s %-*s %-24s %3d %12s %12s %8s %6s %12s %8s %6s  %s\n", rank.c_str(), width, c->name.c_str(),
                StatusText(*c).c_str(), c->fit.parameters, Number(c->fit.loglik).c_str(),
                c->ranked ? Number(c->aic).c_str() : "-", c->ranked ? Number(c->delta_aic).c_str() : "-",
                c->ranked ? Number(c->aic_weight, "{:.3f}").c_str() : "-", c->ranked ? Number(c->bic).c_str() : "-",
                c->ranked ? Number(c->delta_bic).c_str() : "-",
                c->ranked ? Number(c->bic_weight, "{:.3f}").c_str() : "-", HoldoutText(*c).c_str());
  }
}

// What the ranking says: the best by each criterion, each other model's differences on the
// Burnham–Anderson scale, the marks, and the candidates left out with their reasons.
void PrintMeaning(const std::vector<Candidate>& candidates) {
  const Candidate* aic = Best(candidates, &Candidate::aic_rank);
  const Candidate* bic = Best(candidates, &Candidate::bic_rank);
  const Candidate* held = Best(candidates, &Candidate::holdout_rank);
  std::printf("the structure the data support (lowest BIC): %s; lowest AIC: %s; best held-out forecast: %s\n",
              bic ? bic->name.c_str() : "none", aic ? aic->name.c_str() : "none", held ? held->name.c_str() : "none");
  for (const Candidate* c : TableOrder(candidates)) {
    if (c->ranked && c->bic_rank > 1) {
      std::printf("  %s: dAIC %.1f (%s; Akaike weight %.3g), dBIC %.1f (%s)\n", c->name.c_str(), c->delta_aic,
                  DeltaMeaning(c->delta_aic).c_str(), c->aic_weight, c->delta_bic, DeltaMeaning(c->delta_bic).c_str());
    }
    if (c->ranked && c->fit.status != "ok") {
      std::printf("  * %s: the fit converged but its residual tests refuse it (%s): the criteria assume white "
                  "Gaussian residuals, which its residuals are not\n",
                  c->name.c_str(), c->fit.reason.c_str());
    }
    if (c->ranked && c->fit.samples_fitted < c->fit.samples) {
      std::printf("  † %s: fitted on %ld of %ld samples; its log L is its fitted model's run over all of them (a "
                  "lower bound of its maximum)\n",
                  c->name.c_str(), c->fit.samples_fitted, c->fit.samples);
    }
    if (!c->ranked) {
      std::printf("  not ranked: %s: %s%s%s\n", c->name.c_str(), c->fit.coverage.c_str(),
                  c->fit.reason.empty() ? "" : ": ", c->fit.reason.c_str());
    }
    if (!c->holdout.done && c->holdout.status != "none") {
      std::printf("  no forecast: %s: %s\n", c->name.c_str(), c->holdout.reason.c_str());
    }
  }
  std::printf("rank: by BIC (consistent: it picks the true structure as N grows; AIC, which selects for "
              "prediction, prefers a nested model with one parameter more with probability 0.16 however large N is); "
              "dAIC, dBIC: differences to the lowest (<= 2 substantial support, 4-7 considerably less, > 10 "
              "essentially none); w: the weights exp(-d/2) normalised over the ranked models\n");
}

}  // namespace

namespace {

// --csv: one row per candidate, each column a name and how to read it.
void WriteCsv(const std::string& path, const std::vector<Candidate>& candidates) {
  using Column = std::pair<const char*, std::function<std::string(const Candidate&)>>;
  auto num = [](double v) { return std::isfinite(v) ? fmt::format("{:.17g}", v) : std::string(); };
  auto text = [](const std::string& s) {  // RFC 4180 quoting
    std::string q = "\"";
    for (const char ch : s) q += ch == '"' ? std::string("\"\"") : std::string(1, ch);
    return q + "\"";
  };
  const std::vector<Column> columns = {
      {"file", [&](const Candidate& c) { return text(c.file); }},
      {"name", [&](const Candidate& c) { return text(c.name); }},
      {"status", [](const Candidate& c) { return c.fit.status; }},
      {"ranked", [](const Candidate& c) { return std::string(c.ranked ? "1" : "0"); }},
      {"k", [](const Candidate& c) { return std::to_string(c.fit.parameters); }},
      {"values", [](const Candidate& c) { return std::to_string(c.fit.values); }},
      {"loglik", [&](const Candidate& c) { return num(c.fit.loglik); }},
      {"aic", [&](const Candidate& c) { return c.ranked ? num(c.aic) : ""; }},
      {"delta_aic", [&](const Candidate& c) { return c.ranked ? num(c.delta_aic) : ""; }},
      {"aic_weight", [&](const Candidate& c) { return c.ranked ? num(c.aic_weight) : ""; }},
      {"aic_rank", [](const Candidate& c) { return std::to_string(c.aic_rank); }},
      {"bic", [&](const Candidate& c) { return c.ranked ? num(c.bic) : ""; }},
      {"delta_bic", [&](const Candidate& c) { return c.ranked ? num(c.delta_bic) : ""; }},
      {"bic_weight", [&](const Candidate& c) { return c.ranked ? num(c.bic_weight) : ""; }},
      {"bic_rank", [](const Candidate& c) { return std::to_string(c.bic_rank); }},
      {"holdout_by", [](const Candidate& c) { return c.holdout.by; }},
      {"holdout_score", [&](const Candidate& c) { return c.holdout.done ? num(c.holdout.score) : ""; }},
      {"holdout_rank", [](const Candidate& c) { return std::to_string(c.holdout_rank); }},
      {"samples_fitted", [](const Candidate& c) { return std::to_string(c.fit.samples_fitted); }},
      {"samples", [](const Candidate& c) { return std::to_string(c.fit.samples); }},
      {"reason", [&](const Candidate& c) { return text(c.fit.reason.empty() ? c.fit.coverage : c.fit.reason); }},
  };
  std::vector<std::string> head;
  for (const auto& [name, get] : columns) head.emplace_back(name);
  std::string out = fmt::format("{}\n", fmt::join(head, ","));
  for (const Candidate& c : candidates) {
    std::vector<std::string> row;
    for (const auto& [name, get] : columns) row.push_back(get(c));
    out += fmt::format("{}\n", fmt::join(row, ","));
  }
  WriteFileAtomically(path, out);
}

ComparisonSettings SettingsOf(const CompareArgs& args) {
  const ComparisonSettings settings{.holdout = args.holdout,
                                    .holdout_by = HoldoutByFromString(args.holdout_by, "--holdout-by"),
                                    .chain_head = args.chain_head};
  if (std::string error; !settings.IsValid(&error)) {
    if (!(args.holdout >= 0.0 && args.holdout <= 0.9)) BadFlag(fmt::format("--holdout = {}: must be in [0, 0.9]", args.holdout));
    BadFlag(fmt::format("--chain-head = {}: must be in (0, 0.5]", args.chain_head));
  }
  return settings;
}

std::string HoldoutLine(const ComparisonSettings& settings) {
  if (settings.holdout <= 0.0) return "no hold-out";
  if (settings.holdout_by == HoldoutBy::kTail)
    return fmt::format("held out: the last {:g} of each chain", settings.holdout);
  return fmt::format("held out: each chain in turn, its first {:g} setting its initial state", settings.chain_head);
}

int RunCompare(const CompareArgs& args) {
  const ComparisonSettings settings = SettingsOf(args);
  CheckCompareOutputs(args);
  auto read = [&](const SampleData& d) {
    if (settings.holdout > 0.0 && settings.holdout_by == HoldoutBy::kChain && d.chains() < 2)
      BadFlag("--holdout-by chain: " + OneChainReason(d));
    std::printf("compare: %zu candidate models on %s: %zu samples, %ld chain(s), outputs %s; %s\n", args.models.size(),
                d.path.c_str(), d.t.size(), d.chains(), fmt::format("{}", fmt::join(d.state_columns, ",")).c_str(),
                HoldoutLine(settings).c_str());
  };
  auto fitted = [](const Candidate& c) {
    std::printf("  %s (%s): %s%s%s\n", c.file.c_str(), c.name.c_str(), c.fit.status.c_str(),
                c.fit.route.empty() ? "" : ", route: ", c.fit.route.c_str());
    std::fflush(stdout);
  };
  std::vector<Candidate> candidates;
  try {
    candidates = CompareModels(args.models, args.data, settings, read, fitted);
  } catch (const std::invalid_argument& e) {
    BadFlag(e.what());
  }
  const std::vector<std::string> outputs = candidates.front().fit.outputs;
  PrintTable(candidates, outputs);
  PrintMeaning(candidates);
  if (!args.json.empty()) {
    WriteFileAtomically(args.json, ComparisonJson(args.data, settings, candidates).dump(2) + "\n");
    std::printf("wrote %s\n", args.json.c_str());
  }
  if (!args.csv.empty()) {
    WriteCsv(args.csv, candidates);
    std::printf("wrote %s\n", args.csv.c_str());
  }
  const bool any = std::any_of(candidates.begin(), candidates.end(), [](const Candidate& c) { return c.ranked; });
  if (!any) throw RunFailed("compare: no candidate's fit could be ranked");
  return 0;
}

}  // namespace

void AddCompareCommand(CLI::App& app, Environment&) {
  auto args = std::make_shared<CompareArgs>();
  CLI::App* cmd = app.add_subcommand(
      "compare", "fit candidate model files on the same data and rank them by AIC, BIC and held-out error");
  cmd->add_option("models", args->models, "the candidate model files (TOML), at least 2")->required();
  cmd->add_option("--data", args->data,
                  "CSV, as identify reads it (time, then the measured states; a run column splits it); "
                  "repeat for several runs")
      ->required();
  cmd->add_option("--holdout", args->holdout,
                  "fraction of each chain's last samples held out: each model fitted again without them "
                  "forecasts them (0: no hold-out, by tail or chain)")
      ->capture_default_str();
  cmd->add_option("--holdout-by", args->holdout_by,
                  "tail: hold out each chain's last --holdout fraction; chain: leave each chain (run, or run "
                  "part between gaps) out in turn, fit on the others and the chain's head, forecast the rest "
                  "of it (needs 2 chains or more)")
      ->capture_default_str();
  cmd->add_option("--chain-head", args->chain_head,
                  "--holdout-by chain: the fraction of the left-out chain's first samples that set its initial "
                  "state (fitted with the others, not scored), in (0, 0.5]")
      ->capture_default_str();
  cmd->add_option("--json", args->json, "write the ranking, every fit's criteria, status and estimates as JSON");
  cmd->add_option("--csv", args->csv, "write one row per model: status, k, log L, AIC, BIC, weights, ranks");
  cmd->callback([args] {
    if (const int code = RunCompare(*args); code != 0) throw CLI::RuntimeError(code);
  });
}

}  // namespace hysid::cli
