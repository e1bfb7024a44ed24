#include "experiments/cli/identify_output.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <fstream>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/identify/metrics.hpp"
#include "core/model/automaton.hpp"
#include "core/io/csv.hpp"
#include "core/sets/set_metrics.hpp"
#include "experiments/cli/identify_events.hpp"

namespace hysid::cli {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

std::vector<double> Values(const Vec& v) { return std::vector<double>(v.data(), v.data() + v.size()); }

// One row of the trace: sample k, or (missing set) a row left out, with the chain it sits in.
struct TraceRow {
  std::size_t k = 0;
  const MissingRow* missing = nullptr;
  double chain = kNan;
};

// A trace column: its name and its cell of a row.
struct TraceColumn {
  std::string name;
  std::function<double(const TraceRow&)> cell;
};

// The columns, each described once (docs/outputs.md lists them in this order).
std::vector<TraceColumn> TraceColumns(const ModelSpec& spec, const DetectorDescriptor& detector,
                                      const SampleData& data, const IdentifyResult& result) {
  // A cell a row left out does not have: nan there.
  auto of_sample = [](std::function<double(std::size_t)> f) {
    return [f = std::move(f)](const TraceRow& row) { return row.missing ? kNan : f(row.k); };
  };
  const SampleData* d = &data;
  const IdentifyResult* r = &result;
  std::vector<TraceColumn> cols{
      {"run",
       [d](const TraceRow& row) { return double((row.missing ? row.missing->run : d->run[row.k]) + 1); }},
      {"chain", [](const TraceRow& row) { return row.chain; }},
      {"line", [d](const TraceRow& row) { return double(row.missing ? row.missing->line : d->line[row.k]); }},
      {"t", [d](const TraceRow& row) { return row.missing ? row.missing->t : d->t[row.k]; }},
      {"missing", [](const TraceRow& row) { return row.missing ? 1.0 : 0.0; }},
      {std::string(detector.traits.statistic), of_sample([r](std::size_t k) { return r->statistic[k]; })},
      {std::string(detector.traits.threshold), of_sample([r](std::size_t k) { return r->threshold[k]; })},
      {"gamma", of_sample([r](std::size_t k) { return double(r->gamma[k]); })}};
  for (const auto& block :
       {std::pair{&spec.alpha, &result.alpha_trace}, std::pair{&spec.beta, &result.beta_trace}}) {
    const auto* list = block.first;
    const Mat* trace = block.second;  // (named, not a structured binding: clang 14 cannot capture those)
    for (std::size_t i = 0; i < list->size(); ++i) {
      if ((*list)[i].known) continue;
      cols.push_back({(*list)[i].name + "_hat", of_sample([trace, i](std::size_t k) {
                        return (*trace)(Eigen::Index(i), Eigen::Index(k));
                      })});
    }
  }
  if (data.j) {
    const std::vector<int>* j = &*data.j;
    cols.push_back({"j", of_sample([j](std::size_t k) { return double((*j)[k]); })});
    cols.push_back(
        {"true_jump", of_sample([j](std::size_t k) { return k > 0 && (*j)[k] != (*j)[k - 1] ? 1.0 : 0.0; })});
  }
  return cols;
}

// The detector's options that it reads, by name: numbers, or the choice's name.
nlohmann::json DetectorOptionsJson(const DetectorSettings& s) {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& o : DetectorOptions()) {
    if (!DescriptorOf(s.kind).Reads(o.name)) continue;
    const std::string key(o.name);
    if (o.type == OptionType::kChoice) {
      out[key] = o.Format(o.get(s));
    } else {
      out[key] = o.get(s);
    }
  }
  return out;
}

nlohmann::json DataJson(const SampleData& data) {
  return {{"path", data.path},
          {"state_columns", data.state_columns},
          {"rows", data.t.size() + data.missing.size()},
          {"samples", data.t.size()},
          {"dt", data.dt},
          {"uniform", data.uniform},
          {"runs", data.run_names},
          {"chains", data.chains()},
          {"max_gap", data.max_gap},
          {"gaps", data.gaps},
          {"missing_rows", data.missing_rows},
          {"first_missing_line", data.first_missing_line}};
}

nlohmann::json SettingsJson(const IdentifierSettings& settings, const std::string& accuracy_source) {
  return {{"estimator", ToString(settings.flow_estimator.kind)},
          {"jump_estimator", ToString(settings.jump_estimator.kind)},
          {"detector", ToString(settings.detector.kind)},
          {"detector_options", DetectorOptionsJson(settings.detector)},
          {"data_rtol", settings.data_rtol},
          {"data_atol", settings.data_atol},
          {"data_accuracy_source", accuracy_source},
          {"localize", settings.localize},
          {"second_pass", settings.second_pass}};
}

// The noise shapes C of gtls/frisch and the σ they come from (null entries when not used).
nlohmann::json NoiseJson(const IdentifyResult& r) {
  nlohmann::json out = {{"sigma", nullptr}, {"sigma_estimated", r.noise_sigma_estimated}};
  if (r.noise_sigma.size()) out["sigma"] = Values(r.noise_sigma);
  out["flow_shape_diagonal"] =
      r.flow_noise_shape.size() ? nlohmann::json(Values(r.flow_noise_shape.diagonal())) : nlohmann::json();
  out["jump_shape_diagonal"] =
      r.jump_noise_shape.size() ? nlohmann::json(Values(r.jump_noise_shape.diagonal())) : nlohmann::json();
  return out;
}

nlohmann::json BoxJson(const Mat& box) {
  if (box.size() == 0) return nullptr;
  nlohmann::json out = nlohmann::json::array();
  for (Eigen::Index i = 0; i < box.rows(); ++i) out.push_back({box(i, 0), box(i, 1)});
  return out;
}

nlohmann::json RecursiveResultJson(const IdentifyResult& r) {
  nlohmann::json out = {{"alpha", Values(r.alpha_hat)},           {"beta", Values(r.beta_hat)},
                        {"flow_box", BoxJson(r.flow_box)},        {"jump_box", BoxJson(r.jump_box)},
                        {"jumps_detected", r.jumps_detected},     {"jumps_localized", r.jumps_localized},
                        {"sets_skipped", r.sets_skipped},         {"flow_hull_vertices", r.flow_hull.cols()},
                        {"flow_hull_volume", r.flow_hull_volume}, {"jump_hull_vertices", r.jump_hull.cols()},
                        {"jump_hull_volume", r.jump_hull_volume}, {"second_pass", nullptr}};
  if (r.second_pass) {
    out["second_pass"] = {
        {"flow_to_jump", r.reclassified_to_jump},
        {"jump_to_flow", r.reclassified_to_flow},
        {"first_pass_jumps", std::count(r.first_pass_gamma.begin(), r.first_pass_gamma.end(), 1)},
        {"first_pass_alpha", Values(r.first_pass_alpha_hat)},
        {"first_pass_beta", Values(r.first_pass_beta_hat)}};
  }
  return out;
}

// Every sample the detector flagged (γ = 1): its index, run, chain, line and time.
nlohmann::json DetectionsJson(const SampleData& data, const IdentifyResult& r,
                              const std::vector<long>& chain) {
  nlohmann::json out = nlohmann::json::array();
  for (std::size_t k = 0; k < r.gamma.size(); ++k) {
    if (!r.gamma[k]) continue;
    out.push_back({{"sample", k},
                   {"run", data.run[k] + 1},
                   {"chain", chain[k]},
                   {"line", data.line[k]},
                   {"t", data.t[k]}});
  }
  return out;
}

// Per chain: where it is, and what the recursive estimators did with it (each sample after the
// chain's first is one flow or one jump update).
nlohmann::json ChainsJson(const SampleData& data, const IdentifyResult& r, const std::vector<long>& chain) {
  nlohmann::json out = nlohmann::json::array();
  for (std::size_t first = 0, end = 0; first < data.t.size(); first = end) {
    for (end = first + 1; end < data.t.size() && !data.chain_start[end];) ++end;
    const long samples = static_cast<long>(end - first);
    const long jumps =
        std::count(r.gamma.begin() + static_cast<long>(first), r.gamma.begin() + static_cast<long>(end), 1);
    out.push_back({{"chain", chain[first]},
                   {"run", data.run[first] + 1},
                   {"first_sample", first},
                   {"first_line", data.line[first]},
                   {"t_first", data.t[first]},
                   {"t_last", data.t[end - 1]},
                   {"samples", samples},
                   {"jumps", jumps},
                   {"flow_updates", samples - 1 - jumps},
                   {"jump_updates", jumps}});
  }
  return out;
}

// Against the data's column j and the model's true values and sets (as PrintTruth).
nlohmann::json TruthJson(const Model& model, const std::vector<int>& j, const IdentifyResult& r) {
  const Confusion c = CompareJumps(j, r.gamma);
  const ParameterErrors e = CompareParameters(model, r.alpha_hat, r.beta_hat);
  nlohmann::json out = {{"true_jumps", c.tp + c.fn},
                        {"tp", c.tp},
                        {"fp", c.fp},
                        {"fn", c.fn},
                        {"tn", c.tn},
                        {"misclassification", c.misclassification()},
                        {"precision", c.precision()},
                        {"recall", c.recall()},
                        {"e_alpha", e.e_alpha},
                        {"e_beta", e.e_beta},
                        {"rel_alpha", e.rel_alpha},
                        {"rel_beta", e.rel_beta},
                        {"sets", nullptr}};
  if (r.sets_skipped.empty() && model.input_size() == 0) {  // C, D of a model with inputs move with u
    const SetMetrics sm = CompareSets(model, r.flow_hull, r.jump_hull);
    out["sets"] = {{"flow_outside_share", sm.flow_outside_share},
                   {"jump_hausdorff",
                    model.has_jump_set_distance() ? nlohmann::json(sm.jump_hausdorff) : nlohmann::json()}};
  }
  return out;
}

}  // namespace

std::vector<long> ChainNumbers(const SampleData& data) {
  std::vector<long> chain(data.t.size());
  long c = 0;
  for (std::size_t k = 0; k < data.t.size(); ++k) chain[k] = c += data.chain_start[k];
  return chain;
}

void WriteTrace(const std::string& path, const ModelSpec& spec, const DetectorDescriptor& detector,
                const SampleData& data, const IdentifyResult& result) {
  const std::vector<TraceColumn> cols = TraceColumns(spec, detector, data, result);
  std::vector<std::string> header;
  for (const TraceColumn& c : cols) header.push_back(c.name);
  CsvWriter csv(path, header);
  std::vector<double> cells(cols.size());
  auto write = [&](const TraceRow& row) {
    for (std::size_t c = 0; c < cols.size(); ++c) cells[c] = cols[c].cell(row);
    csv.Row(cells);
  };
  const std::vector<long> chain = ChainNumbers(data);
  const std::size_t samples = data.t.size();
  // A row left out goes before the first sample after it (a later run, or a later line in its run),
  // in the chain of the sample before it in its run (the chain goes on across it), else of the one after.
  std::size_t m = 0;
  for (std::size_t k = 0; k <= samples; ++k) {
    for (; m < data.missing.size(); ++m) {
      const MissingRow& row = data.missing[m];
      if (k < samples && (row.run > data.run[k] || (row.run == data.run[k] && row.line > data.line[k])))
        break;
      const double chain_of = k > 0 && data.run[k - 1] == row.run     ? double(chain[k - 1])
                              : k < samples && data.run[k] == row.run ? double(chain[k])
                                                                      : kNan;
      write({.missing = &row, .chain = chain_of});
    }
    if (k < samples) write({.k = k, .chain = double(chain[k])});
  }
  csv.Commit();
  std::printf("wrote %s (%zu rows: %zu samples, %zu rows with a missing value)\n", path.c_str(),
              samples + data.missing.size(), samples, data.missing.size());
}

std::vector<FitColumn> FitColumns(const ModelSpec& spec, const std::vector<int>& measured, const Mat& y,
                                  const FittedOutputs& f) {
  const auto& names = spec.state_names;
  std::vector<FitColumn> cols;
  for (std::size_t i = 0; i < names.size(); ++i) {
    cols.push_back({"fit_" + names[i], [&f, i](long k) { return f.x(Eigen::Index(i), k); }});
  }
  for (std::size_t i = 0; i < names.size(); ++i) {
    cols.push_back({"sd_" + names[i], [&f, i](long k) { return f.sd(Eigen::Index(i), k); }});
  }
  const bool full = y.rows() == static_cast<Eigen::Index>(names.size());
  for (std::size_t r = 0; r < measured.size(); ++r) {
    const int i = measured[r];
    const Eigen::Index row = full ? i : Eigen::Index(r);
    cols.push_back(
        {"residual_" + names[std::size_t(i)], [&f, &y, i, row](long k) { return y(row, k) - f.matched(i, k); }});
  }
  for (std::size_t i = 0; i < names.size(); ++i) {
    cols.push_back({"recursive_" + names[i], [&f, i](long k) { return f.recursive(Eigen::Index(i), k); }});
  }
  cols.push_back({"in_fit", [&f](long k) { return double(f.in_fit[std::size_t(k)]); }});
  if (!f.mode.empty()) {
    cols.push_back({"mode_fitted", [&f](long k) {
                      return f.mode[std::size_t(k)] >= 0 ? double(f.mode[std::size_t(k)]) : kNan;
                    }});
  }
  return cols;
}

void AppendFitColumns(const std::string& path, const ModelSpec& spec, const std::vector<int>& measured,
                      const Mat& y, const FittedOutputs& f) {
  const std::vector<FitColumn> cols = FitColumns(spec, measured, y, f);
  // The trace is hysid's own file: one record per line, cells of numbers (nan, inf included) after
  // the header; each line is kept as written and the new cells appended.
  std::ifstream in(path);
  std::string line;
  if (!std::getline(in, line)) throw std::runtime_error(fmt::format("{}: cannot read the trace back", path));
  std::vector<std::string> header = SplitCsvLine(line, path, 1);
  const auto at = std::find(header.begin(), header.end(), "missing");
  const auto missing = static_cast<std::size_t>(at - header.begin());
  for (const FitColumn& c : cols) header.push_back(c.name);
  CsvWriter csv(path, header);
  long k = 0, line_no = 1;
  std::vector<double> row;
  while (std::getline(in, line)) {
    const std::vector<std::string> cells_in = SplitCsvLine(line, path, ++line_no);
    row.clear();
    for (const std::string& c : cells_in) row.push_back(std::strtod(c.c_str(), nullptr));
    const bool left_out = missing < cells_in.size() && cells_in[missing] == "1";
    for (const FitColumn& c : cols) row.push_back(left_out || k >= f.x.cols() ? kNan : c.cell(k));
    if (!left_out) ++k;
    csv.Row(row);
  }
  if (k != f.x.cols()) {  // an internal invariant: the trace was written from these samples
    throw std::logic_error(fmt::format("{}: {} samples in the trace, {} fitted", path, k, f.x.cols()));
  }
  csv.Commit();
}

nlohmann::json FittedEventsJson(const ModelSpec& spec, const std::vector<double>& t, const FittedOutputs& f) {
  auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  const bool automaton = IsAutomaton(spec);
  const std::vector<JumpMap> maps = automaton ? JumpMaps(spec) : std::vector<JumpMap>{};
  auto mode_name = [&](int q) {
    return q >= 0 && q < static_cast<int>(spec.modes.size()) ? nlohmann::json(spec.modes[std::size_t(q)])
                                                              : nlohmann::json(q);
  };
  nlohmann::json jumps = nlohmann::json::array();
  for (const FittedJump& j : f.jumps) {
    nlohmann::json e = {{"t", j.time}, {"se", number(j.se)}, {"chain", j.chain + 1}, {"in_fit", j.in_fit}};
    if (automaton) {
      e["map"] = j.map >= 0 && j.map < static_cast<int>(maps.size()) ? nlohmann::json(maps[std::size_t(j.map)].name)
                                                                    : nlohmann::json();
      e["mode_after"] = mode_name(j.mode_after);
    }
    jumps.push_back(e);
  }
  nlohmann::json modes = nlohmann::json::array();
  for (std::size_t k = 0; k < f.mode.size(); ++k) {
    if (f.mode[k] >= 0 && (k == 0 || f.mode[k] != f.mode[k - 1]))
      modes.push_back({{"first_sample", k}, {"t", t[k]}, {"mode", mode_name(f.mode[k])}});
  }
  return {{"jumps", jumps},
          {"modes", f.mode.empty() ? nlohmann::json() : modes},
          {"reason", f.reason},
          {"recursive_reason", f.recursive_reason}};
}

void WriteHulls(const std::string& path, const ModelSpec& spec, const IdentifyResult& result) {
  std::vector<std::string> header{"set", "vertex"};
  header.insert(header.end(), spec.state_names.begin(), spec.state_names.end());
  if (std::find(spec.state_names.begin(), spec.state_names.end(), "set") != spec.state_names.end() ||
      std::find(spec.state_names.begin(), spec.state_names.end(), "vertex") != spec.state_names.end()) {
    for (std::size_t i = 0; i < spec.state_names.size(); ++i) header[2 + i] = fmt::format("x{}", i + 1);
  }
  CsvWriter csv(path, header);
  std::vector<double> row(header.size());
  int set = 0;
  for (const Mat* hull : {&result.flow_hull, &result.jump_hull}) {
    for (Eigen::Index v = 0; v < hull->cols(); ++v) {
      row[0] = set;
      row[1] = static_cast<double>(v);
      for (Eigen::Index i = 0; i < hull->rows(); ++i) row[static_cast<std::size_t>(2 + i)] = (*hull)(i, v);
      csv.Row(row);
    }
    ++set;
  }
  csv.Commit();
  std::printf("wrote %s (set 0 = flow hull C^, set 1 = jump hull D^, vertices in order)\n", path.c_str());
}

nlohmann::json RecursiveJson(const Model& model, const SampleData& data, const IdentifierSettings& settings,
                             const std::string& accuracy_source, const IdentifyResult& result) {
  const std::vector<long> chain = ChainNumbers(data);
  nlohmann::json out = {{"model", model.spec().name},
                        {"data", DataJson(data)},
                        {"settings", SettingsJson(settings, accuracy_source)},
                        {"noise", NoiseJson(result)},
                        {"recursive", RecursiveResultJson(result)},
                        {"detections", DetectionsJson(data, result, chain)},
                        {"chains", ChainsJson(data, result, chain)},
                        {"automaton", EventsJson(model, data, result)},
                        {"truth", nullptr}};
  if (data.j) out["truth"] = TruthJson(model, *data.j, result);
  return out;
}

}  // namespace hysid::cli
