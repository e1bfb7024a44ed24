#include "experiments/sweep/tables.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

#include "core/io/csv.hpp"
#include "core/io/limits.hpp"
#include "core/stats/quantiles.hpp"
#include "experiments/sweep/journal.hpp"
#include "experiments/sweep/trial.hpp"

namespace hysid {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

long Column(const std::vector<std::string>& header, const std::string& name) {
  const auto it = std::find(header.begin(), header.end(), name);
  if (it == header.end()) throw std::logic_error(fmt::format("trials table has no column '{}'", name));
  return it - header.begin();
}

// A metric cell of a unit's row; a cell that is not a number (a corrupt row) is named, not guessed.
double MetricValue(const std::string& text, long unit, const std::string& column) {
  double v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size()) {
    throw std::invalid_argument(
        fmt::format("the row of unit {}: column '{}': '{}' is not a number", unit, column, Abbreviated(text)));
  }
  return v;
}

}  // namespace

std::vector<std::string> JournalHeader(const std::vector<std::string>& trial_header) {
  std::vector<std::string> h = trial_header;
  h.push_back("wall_ms");
  return h;
}

MetricSummary Summarize(std::vector<double> v) {
  MetricSummary s{static_cast<long>(v.size()), kNaN, kNaN, kNaN, kNaN, kNaN};
  if (v.empty()) return s;
  double sum = 0;
  for (double x : v) sum += x;
  s.mean = sum / static_cast<double>(v.size());
  std::sort(v.begin(), v.end());
  const std::size_t h = v.size() / 2;
  s.median = v.size() % 2 ? v[h] : 0.5 * (v[h - 1] + v[h]);
  if (v.size() >= 2) {
    double ss = 0;
    for (double x : v) ss += (x - s.mean) * (x - s.mean);
    s.std = std::sqrt(ss / static_cast<double>(v.size() - 1));
    const double half = StudentUpperQuantile(0.025, static_cast<double>(v.size() - 1)) * s.std /
                        std::sqrt(static_cast<double>(v.size()));
    s.ci_lo = s.mean - half;
    s.ci_hi = s.mean + half;
  }
  return s;
}

void WriteSweepTables(const std::filesystem::path& dir, const std::vector<std::string>& trial_header,
                      const std::map<long, std::vector<std::string>>& rows) {
  const std::size_t nt = trial_header.size();
  {
    CsvWriter trials(dir / "trials.csv", trial_header);
    CsvWriter timings(dir / "timings.csv", {"unit", "cell", "trial", "wall_ms"});
    for (const auto& [unit, cells] : rows) {
      trials.TextRow(std::span<const std::string>(cells.data(), nt));
      const std::string t[] = {cells[0], cells[1], cells[2], cells.back()};
      timings.TextRow(t);
    }
    trials.Commit();
    timings.Commit();
  }

  // summary.csv
  const std::vector<std::string> keys{"cell", "model", "dt", "sigma", "r", "false_alarm", "estimator", "detector"};
  const std::vector<std::string>& metrics = SummaryMetrics();
  std::vector<long> key_col, metric_col;
  for (const auto& k : keys) key_col.push_back(Column(trial_header, k));
  for (const auto& m : metrics) metric_col.push_back(Column(trial_header, m));
  const long cell_col = Column(trial_header, "cell"), status_col = Column(trial_header, "status");

  std::vector<std::string> header = keys;
  header.insert(header.end(), {"trials", "failures"});
  for (const auto& m : metrics) {
    for (const char* stat : {"mean", "median", "std", "ci95_lo", "ci95_hi"}) header.push_back(m + "_" + stat);
  }
  CsvWriter summary(dir / "summary.csv", header);
  // Rows are sorted by unit = cell·trials + trial, so each cell's rows are contiguous.
  auto it = rows.begin();
  while (it != rows.end()) {
    const std::string cell = it->second[static_cast<std::size_t>(cell_col)];
    std::vector<std::string> out;
    for (long c : key_col) out.push_back(it->second[static_cast<std::size_t>(c)]);
    long n = 0, failures = 0;
    std::vector<std::vector<double>> values(metrics.size());
    for (; it != rows.end() && it->second[static_cast<std::size_t>(cell_col)] == cell; ++it) {
      const auto& cells = it->second;
      ++n;
      if (cells[static_cast<std::size_t>(status_col)] != kTrialOk) {
        ++failures;
        continue;
      }
      for (std::size_t m = 0; m < metrics.size(); ++m) {
        const std::string& text = cells[static_cast<std::size_t>(metric_col[m])];
        if (!text.empty()) values[m].push_back(MetricValue(text, it->first, metrics[m]));
      }
    }
    out.push_back(fmt::format("{}", n));
    out.push_back(fmt::format("{}", failures));
    for (auto& v : values) {
      const MetricSummary s = Summarize(std::move(v));
      for (double x : {s.mean, s.median, s.std, s.ci_lo, s.ci_hi}) out.push_back(FormatNumber(x));
    }
    summary.TextRow(out);
  }
  summary.Commit();
}

void ReadTrialsCsv(const std::filesystem::path& path, std::vector<std::string>* header,
                   std::map<long, std::vector<std::string>>* rows) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument(fmt::format("{}: cannot open", path.string()));
  std::string line;
  long line_no = 0;
  while (ReadBoundedLine(in, line, path.string(), line_no + 1)) {
    ++line_no;
    std::vector<std::string> cells = SplitCsvLine(line);
    if (line_no == 1) {
      *header = std::move(cells);
      continue;
    }
    if (cells.size() != header->size()) {
      throw std::invalid_argument(fmt::format("{}:{}: {} cells, expected {}", path.string(), line_no,
                                              cells.size(), header->size()));
    }
    long unit = 0;
    const auto [end, ec] = std::from_chars(cells[0].data(), cells[0].data() + cells[0].size(), unit);
    if (ec != std::errc() || end != cells[0].data() + cells[0].size() || unit < 0) {
      throw std::invalid_argument(fmt::format("{}:{}: column 1 ('unit'): '{}' is not a unit id", path.string(),
                                              line_no, Abbreviated(cells[0])));
    }
    if (!rows->emplace(unit, std::move(cells)).second) {
      throw std::invalid_argument(fmt::format("{}:{}: unit {} appears twice", path.string(), line_no, unit));
    }
  }
  if (line_no == 0) throw std::invalid_argument(fmt::format("{}: empty file", path.string()));
}

}  // namespace hysid
