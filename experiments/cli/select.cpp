// hysid identify with candidate terms: select, bootstrap, drop what the refined fit does not support,
// write the chosen model.
#include "experiments/cli/select.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <limits>
#include <map>
#include <set>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "core/io/files.hpp"
#include "core/model/automaton.hpp"
#include "core/model/regression.hpp"
#include "core/model_file/chosen.hpp"
#include "core/model_file/model_file.hpp"
#include "core/stats/quantiles.hpp"
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

namespace {

// One candidate's line: its name, term, whether chosen, its estimate and its bootstrap share (column i
// of `s` and `bootstrap`).
void PrintTerm(const std::string& name, const std::string& term, const Selection& s, const BootstrapResult& bootstrap,
               std::size_t i) {
  std::string line = fmt::format("  {:<8} {:<22} {:<6}", name, term, s.chosen[i] ? "chosen" : "-");
  if (s.chosen[i]) line += fmt::format(" {:<14.8g}", s.estimate[Eigen::Index(i)]);
  else line += fmt::format(" {:<14}", "");
  if (bootstrap.draws > 0)
    line += fmt::format(" chosen in {:5.1f}% of bootstrap draws", 100.0 * bootstrap.frequency[Eigen::Index(i)]);
  std::printf("%s\n", line.c_str());
}

// Whose detections a selection step summed.
std::string Detections(const SelectStep& step) {
  return step.round == 1 ? "the detections of the pass with every candidate"
                         : fmt::format("the detections of the chosen model, round {}", step.round);
}

// A selection's chosen terms with its held-out mean square and BIC against the runner-up's.
void PrintChosen(const std::vector<std::string>& kept, const Selection& s) {
  std::printf("  chosen: %s (held-out mean square %.6g; BIC %.2f, the least BIC of another support %s)\n",
              kept.empty() ? "no candidate" : fmt::format("{}", fmt::join(kept, ", ")).c_str(), s.cv, s.bic,
              std::isfinite(s.runner_up_bic) ? fmt::format("{:+.2f}", s.runner_up_bic - s.bic).c_str() : "none");
}

// One block's report: its selection, its candidates with their estimates and bootstrap shares.
void PrintBlock(const SelectStep& step, const SelectBlock& block) {
  const Selection& s = block.selection;
  std::size_t candidates = 0;
  std::vector<std::string> kept;
  for (std::size_t i = 0; i < block.positions.size(); ++i) {
    const std::size_t j = std::size_t(block.positions[i]);
    if (!step.selectable[j]) continue;
    ++candidates;
    if (s.chosen[i]) kept.push_back(step.names[j]);
  }
  std::printf("selection%s: %zu candidate terms, %d flow segments (%s), %ld integral "
              "rows; %d supports from thresholded least squares, backward and forward selection and every "
              "support of at most %d candidates, chosen by cross-validation over the segments\n",
              block.mode_name.empty() ? "" : fmt::format(" in mode {}", block.mode_name).c_str(), candidates,
              block.segments,
              Detections(step).c_str(),
              s.rows, s.supports, SelectOptions{}.exhaustive);
  PrintChosen(kept, s);
  for (std::size_t i = 0; i < block.positions.size(); ++i) {
    const std::size_t j = std::size_t(block.positions[i]);
    if (step.selectable[j]) PrintTerm(step.names[j], step.terms[j], s, block.bootstrap, i);
  }
  if (block.bootstrap.draws > 0) {
    std::printf("  bootstrap: %d draws of the flow segments with replacement; the cross-validated support "
                "exactly in %d\n",
                block.bootstrap.draws, block.bootstrap.support_matches);
  }
}

// The jump selection's report, as a block's.
void PrintJumps(const SelectStep& step, const JumpSelect& jump) {
  const Selection& s = jump.selection;
  std::vector<std::string> kept;
  std::size_t candidates = 0;
  for (std::size_t j = 0; j < jump.columns.size(); ++j) {
    if (!jump.selectable[j]) continue;
    ++candidates;
    if (s.chosen[j]) kept.push_back(jump.names[j]);
  }
  std::printf("selection of jump terms%s: %zu candidate terms, %d jumps (%s), %ld jump rows; %d supports from "
              "thresholded least squares, backward and forward selection and every support of at most %d "
              "candidates, chosen by leave-one-jump-out cross-validation\n",
              jump.map.empty() ? "" : fmt::format(" of map {}", jump.map).c_str(), candidates, jump.jumps,
              Detections(step).c_str(),
              s.rows, s.supports, SelectOptions{}.exhaustive);
  PrintChosen(kept, s);
  for (std::size_t j = 0; j < jump.columns.size(); ++j) {
    if (jump.selectable[j]) PrintTerm(jump.names[j], jump.terms[j], s, jump.bootstrap, j);
  }
  if (jump.bootstrap.draws > 0) {
    std::printf("  bootstrap: %d draws of the jumps with replacement; the cross-validated support exactly in %d\n",
                jump.bootstrap.draws, jump.bootstrap.support_matches);
  }
  for (const int j : jump.unstable) {
    std::printf("  dropped as unstable: %s (chosen by cross-validation, by %.1f%% of the bootstrap draws, "
                "fewer than %.0f%%)\n",
                jump.names[std::size_t(j)].c_str(), 100.0 * jump.bootstrap.frequency[Eigen::Index(j)],
                100.0 * SelectOptions{}.min_share);
  }
}

}  // namespace

void PrintSelection(const SelectStep& step) {
  for (const SelectBlock& block : step.blocks) PrintBlock(step, block);
  for (const JumpSelect& jump : step.jumps) PrintJumps(step, jump);
  for (const int j : step.unstable) {
    std::printf("  dropped as unstable: %s (chosen by cross-validation, by %.1f%% of the bootstrap draws, "
                "fewer than %.0f%%)\n",
                step.names[std::size_t(j)].c_str(), 100.0 * step.bootstrap.frequency[Eigen::Index(j)],
                100.0 * SelectOptions{}.min_share);
  }
  std::printf("selection time: %.2f s\n", step.seconds);
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
                 "entries, or beta entries for the jump's, the estimates as values) to this file");
  cmd.add_option("--select-bootstrap", args.bootstrap,
                 "a model file with candidate terms: bootstrap draws of the flow segments (of the jumps) for how often each "
                 "term is chosen; a term chosen by fewer than half of them is dropped (0: no bootstrap, "
                 "nothing dropped)")
      ->capture_default_str();
  cmd.add_option("--select-seed", args.seed, "seed of the selection's bootstrap")->capture_default_str()
      ->transform(NonNegativeInteger);
}

void CheckSelectArgs(const SelectArgs& args, const Model& model) {
  if (!args.chosen_model.empty() && model.spec().candidates.empty() && model.spec().jump_candidates.empty()) {
    BadFlag(fmt::format(
        "--chosen-model: model '{}' has no candidate terms ([flow], [[flow]], [jump] or [[jump]] candidates) to choose from",
        model.name()));
  }
  if (args.bootstrap < 0 || args.bootstrap > 100000)
    BadFlag(fmt::format("--select-bootstrap = {}: must be in [0, 100000]", args.bootstrap));
}

namespace {

// The full model's unknown α columns and, per column, whether it is a candidate, its name and term.
void DescribeColumns(const Model& model, SelectStep* step) {
  step->columns = RegressionLayout::Flow(model).unknown;
  for (int a : step->columns) {
    const CandidateTerm* c = CandidateOf(model.spec(), a);
    step->selectable.push_back(c != nullptr);
    step->names.push_back(model.spec().alpha[std::size_t(a)].name);
    step->terms.push_back(c ? TermText(model.spec(), a) : "");
    step->rows.push_back(c ? model.spec().state_names[std::size_t(c->row)] : "");
    step->raw_terms.push_back(c ? c->term : "");
    step->term_modes.push_back(c && ModeCount(model.spec()) > 1 ? model.spec().modes[std::size_t(c->mode)] : "");
  }
}

// The selection of mode q's candidates on the pairs of the detected hybrid time domain in mode q,
// over the columns φ_q has; the bootstrap and the stability rule when `bootstrap`.
// `cross_validated`: the selection before the stability rule.
SelectBlock SelectMode(const Model& model, const SampleData& data, const IdentifyResult& detected,
                       const SelectArgs& args, bool bootstrap, const SelectStep& step, int q,
                       Selection* cross_validated) {
  const bool moded = ModeCount(model.spec()) > 1;
  const FlowSamples samples{.y = &data.y,
                            .gamma = &detected.gamma,
                            .dt = data.dt,
                            .times = data.uniform ? nullptr : &data.t,
                            .chain_start = data.uniform ? nullptr : &data.chain_start,
                            .inputs = data.u.rows() > 0 ? &data.u : nullptr,
                            .modes = moded ? &detected.mode : nullptr,
                            .mode = q,
                            .margin = moded ? KinkSettings{}.window : 0};
  const FlowSums all = SumFlowSegments(model, samples);
  SelectBlock block;
  block.mode = q;
  block.mode_name = moded ? model.spec().modes[std::size_t(q)] : "";
  block.positions = ColumnsInUse(all);
  const FlowSums sums = KeepColumns(all, block.positions);
  block.segments = static_cast<int>(sums.segments.size());
  std::vector<bool> selectable;
  for (int j : block.positions) selectable.push_back(step.selectable[std::size_t(j)]);
  block.selection = SelectTerms(sums, selectable, SelectOptions{});
  if (!block.selection.ok) {
    throw RunFailed(fmt::format("identify: no terms selected{}: {}",
                                moded ? fmt::format(" in mode {}", block.mode_name) : "", block.selection.reason));
  }
  *cross_validated = block.selection;
  if (bootstrap && args.bootstrap > 0) {
    block.bootstrap = BootstrapSelection(sums, selectable, SelectOptions{}, args.bootstrap,
                                         args.seed + std::uint64_t(q), block.selection.chosen);
    block.selection = KeepStable(sums, selectable, block.selection, block.bootstrap, SelectOptions{});
  }
  return block;
}

// The blocks' selections per column of the step (the struct's comment).
void MergeBlocks(SelectStep* step, const std::vector<Selection>& before_stability) {
  const std::size_t p = step->columns.size();
  Selection& m = step->selection;
  m.ok = true;
  m.chosen.assign(p, false);
  m.estimate = Vec::Zero(Eigen::Index(p));
  m.runner_up_bic = std::numeric_limits<double>::infinity();
  step->bootstrap.frequency = Vec::Zero(Eigen::Index(p));
  std::vector<bool> seen(p, false);
  for (std::size_t j = 0; j < p; ++j) m.chosen[j] = !step->selectable[j];
  for (std::size_t b = 0; b < step->blocks.size(); ++b) {
    const SelectBlock& block = step->blocks[b];
    for (std::size_t i = 0; i < block.positions.size(); ++i) {
      const std::size_t j = std::size_t(block.positions[i]);
      if (step->selectable[j]) m.chosen[j] = block.selection.chosen[i];
      if (!seen[j]) m.estimate[Eigen::Index(j)] = block.selection.estimate[Eigen::Index(i)];
      if (block.bootstrap.draws > 0 && step->selectable[j])
        step->bootstrap.frequency[Eigen::Index(j)] = block.bootstrap.frequency[Eigen::Index(i)];
      if (step->selectable[j] && before_stability[b].chosen[i] && !block.selection.chosen[i])
        step->unstable.push_back(static_cast<int>(j));
      seen[j] = true;
    }
    m.bic += block.selection.bic;
    m.cv += block.selection.cv;
    m.rows += block.selection.rows;
    m.supports += block.selection.supports;
    step->segments += block.segments;
    step->bootstrap.draws = b == 0 ? block.bootstrap.draws : std::min(step->bootstrap.draws, block.bootstrap.draws);
    step->bootstrap.support_matches = b == 0 ? block.bootstrap.support_matches
                                             : std::min(step->bootstrap.support_matches, block.bootstrap.support_matches);
  }
  if (step->blocks.size() == 1) {
    m.runner_up_bic = step->blocks.front().selection.runner_up_bic;
    m.runner_up.clear();
  }
}

// The unknown β columns of the [jump] (of a map) and, per column, whether it is a candidate, its name and term.
void DescribeJumpColumns(const ModelSpec& spec, const std::vector<int>& columns, JumpSelect* jump) {
  jump->columns = columns;
  for (int b : columns) {
    const JumpCandidateTerm* c = nullptr;
    for (const JumpCandidateTerm& t : spec.jump_candidates)
      if (t.beta == b) c = &t;
    jump->selectable.push_back(c != nullptr);
    jump->names.push_back(spec.beta[std::size_t(b)].name);
    jump->rows.push_back(c ? spec.state_names[std::size_t(c->row)] : "");
    jump->terms.push_back(c ? fmt::format("{}+ term {}", jump->rows.back(), c->term) : "");
    jump->raw_terms.push_back(c ? c->term : "");
  }
}

// Per sample k, the map of the detected jump between k − 1 and k (−1: none), from the events' assignments.
std::vector<int> JumpMapsPerSample(const IdentifyResult& detected, Eigen::Index samples) {
  std::vector<int> maps(std::size_t(samples), -1);
  for (const AutomatonEvent& e : detected.events) {
    if (e.jump && e.map >= 0 && e.sample > 0 && e.sample < samples) maps[std::size_t(e.sample)] = e.map;
  }
  return maps;
}

// The selection of the [jump]'s candidates (map −1) or of map `map`'s on its detected jumps, over the
// map's β slice, by leave-one-jump-out cross-validation (SelectOptions::folds = 0); the bootstrap (seed
// --select-seed + the mode count + the map's index + 1) and the stability rule when `bootstrap`.
JumpSelect SelectJumps(const Model& model, const SampleData& data, const IdentifyResult& detected,
                       const SelectArgs& args, bool bootstrap, int map) {
  const std::vector<int> maps = map >= 0 ? JumpMapsPerSample(detected, data.y.cols()) : std::vector<int>{};
  const JumpSamples samples{.y = &data.y,
                            .gamma = &detected.gamma,
                            .dt = data.dt,
                            .times = data.uniform ? nullptr : &data.t,
                            .chain_start = data.uniform ? nullptr : &data.chain_start,
                            .inputs = data.u.rows() > 0 ? &data.u : nullptr,
                            .maps = map >= 0 ? &maps : nullptr,
                            .map = std::max(map, 0)};
  FlowSums sums = SumJumps(model, samples);
  if (map >= 0) {
    const JumpMap& m = model.spec().jumps[std::size_t(map)];
    std::vector<int> slice;
    for (std::size_t j = 0; j < sums.columns.size(); ++j) {
      if (sums.columns[j] >= m.beta_first && sums.columns[j] < m.beta_first + m.beta_count)
        slice.push_back(static_cast<int>(j));
    }
    sums = KeepColumns(sums, slice);
  }
  JumpSelect jump;
  jump.map = map >= 0 ? model.spec().jumps[std::size_t(map)].name : "";
  DescribeJumpColumns(model.spec(), sums.columns, &jump);
  jump.jumps = static_cast<int>(sums.segments.size());
  const SelectOptions options{.folds = 0};
  jump.selection = SelectTerms(sums, jump.selectable, options);
  if (!jump.selection.ok) {
    throw RunFailed(fmt::format("identify: no jump terms selected{}: {}",
                                jump.map.empty() ? "" : fmt::format(" in map {}", jump.map), jump.selection.reason));
  }
  if (!bootstrap || args.bootstrap == 0) return jump;
  const Selection cross_validated = jump.selection;
  jump.bootstrap = BootstrapSelection(sums, jump.selectable, options, args.bootstrap,
                                      args.seed + std::uint64_t(ModeCount(model.spec())) + std::uint64_t(map + 1),
                                      cross_validated.chosen);
  jump.selection = KeepStable(sums, jump.selectable, cross_validated, jump.bootstrap, options);
  for (std::size_t j = 0; j < jump.columns.size(); ++j) {
    if (jump.selectable[j] && cross_validated.chosen[j] && !jump.selection.chosen[j])
      jump.unstable.push_back(static_cast<int>(j));
  }
  return jump;
}

}  // namespace

SelectStep SelectCandidates(const Model& model, const std::string& file, const SampleData& data,
                            const IdentifyResult& detected, const SelectArgs& args, bool bootstrap) {
  const auto start = std::chrono::steady_clock::now();
  SelectStep step;
  step.file = file;
  step.text = ReadWholeFile(file, "model file");
  DescribeColumns(model, &step);
  std::set<int> modes;
  for (const CandidateTerm& c : model.spec().candidates) modes.insert(c.mode);
  step.per_mode = ModeCount(model.spec()) > 1;
  std::vector<Selection> before;
  for (const int q : modes) {
    before.emplace_back();
    step.blocks.push_back(SelectMode(model, data, detected, args, bootstrap, step, q, &before.back()));
  }
  MergeBlocks(&step, before);
  std::map<std::string, double> values;
  for (std::size_t j = 0; j < step.columns.size(); ++j) {
    const std::string& name = model.spec().alpha[std::size_t(step.columns[j])].name;
    if (step.selectable[j] && step.selection.chosen[j]) step.kept.push_back(name);
    // A column no mode's selection summed (its estimate left at 0) keeps the file's value.
    if (step.selection.chosen[j] && step.selection.estimate[Eigen::Index(j)] != 0.0)
      values[name] = step.selection.estimate[Eigen::Index(j)];
  }
  std::set<int> maps;
  for (const JumpCandidateTerm& c : model.spec().jump_candidates) maps.insert(c.map);
  for (const int map : maps) {
    step.jumps.push_back(SelectJumps(model, data, detected, args, bootstrap, map));
    const JumpSelect& jump = step.jumps.back();
    const Selection& s = jump.selection;
    for (std::size_t j = 0; j < jump.columns.size(); ++j) {
      if (jump.selectable[j] && s.chosen[j]) step.kept.push_back(jump.names[j]);
      if (s.chosen[j] && s.estimate[Eigen::Index(j)] != 0.0) values[jump.names[j]] = s.estimate[Eigen::Index(j)];
    }
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

// The jump selection as JSON: its terms as the flow's, its support, counts and bootstrap.
nlohmann::json JumpJson(const JumpSelect& jump) {
  const Selection& s = jump.selection;
  nlohmann::json terms = nlohmann::json::array();
  std::vector<std::string> chosen, unstable;
  for (std::size_t j = 0; j < jump.columns.size(); ++j) {
    if (!jump.selectable[j]) continue;
    if (s.chosen[j]) chosen.push_back(jump.names[j]);
    terms.push_back({{"name", jump.names[j]},
                     {"row", jump.rows[j]},
                     {"term", jump.raw_terms[j]},
                     {"chosen", bool(s.chosen[j])},
                     {"estimate", s.estimate[Eigen::Index(j)]},
                     {"bootstrap_frequency", jump.bootstrap.draws > 0
                                                 ? nlohmann::json(jump.bootstrap.frequency[Eigen::Index(j)])
                                                 : nlohmann::json()}});
  }
  for (const int j : jump.unstable) unstable.push_back(jump.names[std::size_t(j)]);
  return {{"terms", terms},
          {"chosen", chosen},
          {"bic", s.bic},
          {"runner_up_bic", std::isfinite(s.runner_up_bic) ? nlohmann::json(s.runner_up_bic) : nlohmann::json()},
          {"rows", s.rows},
          {"jumps", jump.jumps},
          {"supports", s.supports},
          {"bootstrap_draws", jump.bootstrap.draws},
          {"bootstrap_support_matches", jump.bootstrap.support_matches},
          {"unstable", unstable}};
}

// The candidates the refined fit dropped, in order: name, z², threshold.
nlohmann::json FitDropsJson(const std::vector<FitDrop>& drops) {
  nlohmann::json out = nlohmann::json::array();
  for (const FitDrop& d : drops) out.push_back({{"name", d.name}, {"z2", d.z2}, {"threshold", d.threshold}});
  return out;
}

// The jump selections as JSON, shaped as the file: one object for [jump]; for [[jump]] maps an array,
// one object per map with candidates with its name under "map"; null without jump candidates.
nlohmann::json JumpsJson(const std::vector<JumpSelect>& jumps) {
  if (jumps.empty()) return nlohmann::json();
  if (jumps.size() == 1 && jumps.front().map.empty()) return JumpJson(jumps.front());
  nlohmann::json out = nlohmann::json::array();
  for (const JumpSelect& jump : jumps) {
    nlohmann::json j = JumpJson(jump);
    j["map"] = jump.map;
    out.push_back(std::move(j));
  }
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
                     {"mode", step.term_modes[j].empty() ? nlohmann::json() : nlohmann::json(step.term_modes[j])},
                     {"chosen", bool(step.selection.chosen[j])},
                     {"estimate", step.selection.estimate[Eigen::Index(j)]},
                     {"bootstrap_frequency", step.bootstrap.draws > 0
                                                 ? nlohmann::json(step.bootstrap.frequency[Eigen::Index(j)])
                                                 : nlohmann::json()}});
  }
  nlohmann::json modes = nlohmann::json::array();
  for (const SelectBlock& b : step.blocks) {
    std::vector<std::string> chosen;
    for (std::size_t i = 0; i < b.positions.size(); ++i) {
      if (step.selectable[std::size_t(b.positions[i])] && b.selection.chosen[i])
        chosen.push_back(step.names[std::size_t(b.positions[i])]);
    }
    modes.push_back({{"mode", b.mode_name},
                     {"chosen", chosen},
                     {"bic", b.selection.bic},
                     {"runner_up_bic", std::isfinite(b.selection.runner_up_bic) ? nlohmann::json(b.selection.runner_up_bic)
                                                                              : nlohmann::json()},
                     {"rows", b.selection.rows},
                     {"segments", b.segments},
                     {"supports", b.selection.supports},
                     {"bootstrap_draws", b.bootstrap.draws},
                     {"bootstrap_support_matches", b.bootstrap.support_matches}});
  }
  return {{"terms", terms},
          {"modes", step.per_mode ? modes : nlohmann::json()},
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
          {"jump", JumpsJson(step.jumps)},
          {"dropped_by_fit", FitDropsJson(step.dropped_by_fit)},
          {"seconds", step.seconds}};
}

namespace {

// The chosen flags of `step` (flow columns and jump selections) for candidate `name`.
void SetChosen(SelectStep* step, const std::string& name, bool chosen) {
  for (std::size_t j = 0; j < step->names.size(); ++j) {
    if (step->selectable[j] && step->names[j] == name) step->selection.chosen[j] = chosen;
  }
  for (JumpSelect& jump : step->jumps) {
    for (std::size_t j = 0; j < jump.names.size(); ++j) {
      if (jump.selectable[j] && jump.names[j] == name) jump.selection.chosen[j] = chosen;
    }
  }
}

// A refined fit's estimate of each α and β entry, by name.
std::map<std::string, double> RefinedValues(const Model& model, const RefineResult& r) {
  std::map<std::string, double> values;
  const ModelSpec& s = model.spec();
  for (std::size_t a = 0; a < s.alpha.size(); ++a) values[s.alpha[a].name] = r.estimate.alpha[Eigen::Index(a)];
  for (std::size_t b = 0; b < s.beta.size(); ++b) values[s.beta[b].name] = r.estimate.beta[Eigen::Index(b)];
  return values;
}

}  // namespace

void DropUnsupportedTerms(const IdentifyRequest& request, IdentifyOutcome* outcome, SelectStep* step) {
  const double z = NormalUpperQuantile(kFitDropSize / 2.0);
  const double threshold = z * z;
  RunRefinement(request, outcome);
  for (;;) {
    const RefineResult& r = outcome->refinement.result;
    if (!r.reported) return;
    const std::map<std::string, double> values = RefinedValues(outcome->model, r);
    FitDrop drop{"", threshold, threshold};
    for (std::size_t i = 0; i < r.names.size() && Eigen::Index(i) < r.standard_errors.size(); ++i) {
      const double se = r.standard_errors[Eigen::Index(i)];
      if (std::find(step->kept.begin(), step->kept.end(), r.names[i]) == step->kept.end() || !(se > 0.0)) continue;
      const double z2 = (values.at(r.names[i]) / se) * (values.at(r.names[i]) / se);
      if (z2 < drop.z2) drop = {r.names[i], z2, threshold};
    }
    if (drop.name.empty()) return;
    SelectStep next = *step;
    next.kept.erase(std::find(next.kept.begin(), next.kept.end(), drop.name));
    IdentifyOutcome fit = *outcome;
    const Model chosen =
        ParseModelFile(ChosenText(next, values, "refined estimates, " + drop.name + " dropped"), step->file + " (chosen)")
            .model;
    RunRecursivePassAgain(request, chosen, &fit);
    fit.recursive_report = nlohmann::json();
    RunRefinement(request, &fit);
    const RefineResult& f = fit.refinement.result;
    if (!f.reported || (r.ok() && !f.ok())) return;
    *step = std::move(next);
    step->chosen = chosen;
    SetChosen(step, drop.name, false);
    step->dropped_by_fit.push_back(drop);
    *outcome = std::move(fit);
  }
}

void PrintFitDrops(const SelectStep& step) {
  for (const FitDrop& d : step.dropped_by_fit) {
    std::printf("  dropped after the refinement: %s (z^2 = %.3g below %.3g, chi-square(1) at 1 - %g; the "
                "chosen model refit without it)\n",
                d.name.c_str(), d.z2, d.threshold, kFitDropSize);
  }
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
  const bool shares = step.bootstrap.draws > 0 || std::any_of(step.jumps.begin(), step.jumps.end(),
                                                               [](const JumpSelect& j) { return j.bootstrap.draws > 0; });
  std::printf("chosen terms (%s estimates%s):\n", fitted ? "refined" : "recursive",
              shares ? ", how often the bootstrap chose each" : "");
  // One chosen term's line: its estimate, its standard error after a refinement, its bootstrap share.
  const auto print = [&](const std::string& name, const std::string& term, const BootstrapResult& b, std::size_t j) {
    double se = std::nan("");
    for (std::size_t k = 0; fitted && k < refined->names.size(); ++k) {
      if (refined->names[k] == name && refined->standard_errors.size() > Eigen::Index(k))
        se = refined->standard_errors[Eigen::Index(k)];
    }
    std::string line = fmt::format("  {:<8} {:<22} = {:<14.10g}", name, term, values.at(name));
    line += std::isfinite(se) ? fmt::format(" ± {:<10.4g}", se) : fmt::format(" {:<12}", "");
    if (b.draws > 0) line += fmt::format(" chosen in {:.1f}%", 100.0 * b.frequency[Eigen::Index(j)]);
    std::printf("%s\n", line.c_str());
  };
  for (std::size_t j = 0; j < step.columns.size(); ++j) {
    if (step.selectable[j] && step.selection.chosen[j]) print(step.names[j], step.terms[j], step.bootstrap, j);
  }
  for (const JumpSelect& jump : step.jumps) {
    for (std::size_t j = 0; j < jump.columns.size(); ++j) {
      if (jump.selectable[j] && jump.selection.chosen[j]) print(jump.names[j], jump.terms[j], jump.bootstrap, j);
    }
  }
  if (args.chosen_model.empty()) return;
  WriteFileAtomically(args.chosen_model,
                      ChosenText(step, values, fitted ? "refined estimates" : "recursive estimates"));
  std::printf("wrote %s\n", args.chosen_model.c_str());
}

}  // namespace hysid::cli
