#include "experiments/cli/identify_output.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

#include "core/io/csv.hpp"
#include "experiments/request/outcome_json.hpp"

namespace hysid::cli {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

// One row of the trace: sample k, or (missing set) a row left out, with the chain it sits in.
struct TraceRow {
  std::size_t k = 0;
  const MissingRow* missing = nullptr;  // a row left out: for a missing cell (kind 1) or as an outlier (2)
  double kind = 0.0;
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
      {"missing", [](const TraceRow& row) { return row.kind; }},
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

}  // namespace

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
  // The rows left out, in file order: for a missing cell, or as an outlier.
  std::vector<std::pair<MissingRow, double>> left;
  for (const MissingRow& row : data.missing) left.emplace_back(row, 1.0);
  for (const OutlierSample& o : data.outliers)
    left.push_back({{.run = o.run, .line = o.line, .t = o.t}, 2.0});
  std::stable_sort(left.begin(), left.end(), [](const auto& a, const auto& b) {
    return std::pair(a.first.run, a.first.line) < std::pair(b.first.run, b.first.line);
  });
  // A row left out goes before the first sample after it (a later run, or a later line in its run),
  // in the chain of the sample before it in its run (the chain goes on across it), else of the one after.
  std::size_t m = 0;
  for (std::size_t k = 0; k <= samples; ++k) {
    for (; m < left.size(); ++m) {
      const MissingRow& row = left[m].first;
      if (k < samples && (row.run > data.run[k] || (row.run == data.run[k] && row.line > data.line[k])))
        break;
      const double chain_of = k > 0 && data.run[k - 1] == row.run     ? double(chain[k - 1])
                              : k < samples && data.run[k] == row.run ? double(chain[k])
                                                                      : kNan;
      write({.missing = &row, .kind = left[m].second, .chain = chain_of});
    }
    if (k < samples) write({.k = k, .chain = double(chain[k])});
  }
  csv.Commit();
  std::printf("wrote %s (%zu rows: %zu samples, %zu rows with a missing value%s)\n", path.c_str(),
              samples + left.size(), samples, data.missing.size(),
              data.outliers.empty() ? "" : fmt::format(", {} outliers", data.outliers.size()).c_str());
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
    const bool left_out = missing < cells_in.size() && cells_in[missing] != "0";
    for (const FitColumn& c : cols) row.push_back(left_out || k >= f.x.cols() ? kNan : c.cell(k));
    if (!left_out) ++k;
    csv.Row(row);
  }
  if (k != f.x.cols()) {  // an internal invariant: the trace was written from these samples
    throw std::logic_error(fmt::format("{}: {} samples in the trace, {} fitted", path, k, f.x.cols()));
  }
  csv.Commit();
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

}  // namespace hysid::cli
