#include "core/io/sample_data.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <span>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/io/block_array.hpp"
#include "core/io/csv.hpp"
#include "core/io/limits.hpp"
#include "core/model/noise_shape.hpp"

namespace hysid {

long SampleData::chains() const { return std::count(chain_start.begin(), chain_start.end(), 1); }

namespace {

struct Columns {
  int time = -1;
  std::vector<int> state;
  int run = -1;
  int j = -1;
  int map = -1, q = -1;    // ground-truth map of the latest jump and mode (a hybrid automaton)
  std::vector<int> input;  // SampleDataOptions::inputs, in that order
};

int FindColumn(const CsvTable& table, const std::string& name) {
  const int c = table.Find(name);
  if (c < 0) {
    throw std::invalid_argument(
        fmt::format("{}:1: SampleDataOptions::columns: no column '{}' (the columns are {})", table.path,
                    Abbreviated(name, 40), fmt::join(table.header, ",")));
  }
  return c;
}

// The columns named by `spec` ("t=NAME", "run=NAME", state names).
Columns NamedColumns(const CsvTable& table, int state_size, const std::vector<std::string>& spec) {
  Columns c;
  c.run = -1;
  bool any_state = false;
  std::string time_entry, run_entry;  // the entry that named the time (run) column
  const auto once = [&](std::string& seen, const std::string& entry, const char* key) {
    if (!seen.empty()) {
      throw std::invalid_argument(
          fmt::format("{}:1: SampleDataOptions::columns: {}= is given twice ({} and {})", table.path, key,
                      Abbreviated(seen, 40), Abbreviated(entry, 40)));
    }
    seen = entry;
  };
  for (const std::string& entry : spec) {
    if (entry.rfind("t=", 0) == 0) {
      once(time_entry, entry, "t");
      c.time = FindColumn(table, entry.substr(2));
    } else if (entry.rfind("run=", 0) == 0) {
      once(run_entry, entry, "run");
      c.run = FindColumn(table, entry.substr(4));
    } else {
      c.state.push_back(FindColumn(table, entry));
      any_state = true;
    }
  }
  if (any_state && static_cast<int>(c.state.size()) != state_size) {
    throw std::invalid_argument(
        fmt::format("{}:1: SampleDataOptions::columns: {} state columns named ({}); the "
                    "model has {} states",
                    table.path, c.state.size(), fmt::join(spec, ","), state_size));
  }
  return c;
}

// Refuses --columns that name one column twice, or the time (given or the first column) as a state.
void CheckDistinctColumns(const CsvTable& table, const Columns& c, const std::vector<std::string>& spec) {
  std::vector<int> used = c.state;
  used.push_back(c.time);
  if (c.run >= 0) used.push_back(c.run);
  std::sort(used.begin(), used.end());
  if (const auto twice = std::adjacent_find(used.begin(), used.end()); twice != used.end()) {
    throw std::invalid_argument(fmt::format(
        "{}:1: SampleDataOptions::columns: column '{}' is named twice ({}; the time is column {}); each "
        "column is one state, the time or the run",
        table.path, Abbreviated(table.header[static_cast<std::size_t>(*twice)], 40), fmt::join(spec, ","),
        c.time + 1));
  }
}

// The columns named `names` (in that order) when every one is present and none is the time, run or j
// column; empty otherwise.
std::vector<int> ColumnsNamed(const CsvTable& table, const std::vector<std::string>& names,
                              const Columns& c) {
  std::vector<int> cols;
  for (const std::string& name : names) {
    const int col = table.Find(name);
    if (col < 0 || col == c.time || col == c.run || col == c.j || col == c.map || col == c.q) return {};
    cols.push_back(col);
  }
  return cols;
}

// The default rule: the columns named after the model's states, or y1..yn (both present: they must
// be the same columns), else the first n columns after time other than j, run and true_*.
std::vector<int> DefaultStateColumns(const CsvTable& table, int state_size, const Columns& c,
                                     const std::vector<std::string>& state_names) {
  std::vector<std::string> generic;
  for (int i = 1; i <= state_size; ++i) generic.push_back(fmt::format("y{}", i));
  const std::vector<int> named = ColumnsNamed(table, state_names, c);
  const std::vector<int> numbered = ColumnsNamed(table, generic, c);
  if (!named.empty() && !numbered.empty() && named != numbered) {
    throw std::invalid_argument(
        fmt::format("{}:1: SampleDataOptions::columns: both the columns named after the model's states ({}) "
                    "and {}..{} are present; name the measured state columns",
                    table.path, fmt::join(state_names, ","), generic.front(), generic.back()));
  }
  if (!named.empty()) return named;
  if (!numbered.empty()) return numbered;
  std::vector<int> state;
  const int cols = static_cast<int>(table.header.size());
  for (int col = 0; col < cols && static_cast<int>(state.size()) < state_size; ++col) {
    if (col == c.time || col == c.run || col == c.j || col == c.map || col == c.q ||
        std::find(c.input.begin(), c.input.end(), col) != c.input.end()) {
      continue;
    }
    const std::string& h = table.header[static_cast<std::size_t>(col)];
    if (h != "j" && h != "run" && h != "map" && h != "q" && !h.starts_with("true_")) state.push_back(col);
  }
  return state;
}

// Refuses a header that names two columns alike (which one is meant would be a guess).
void CheckUniqueNames(const CsvTable& table) {
  std::map<std::string, std::size_t> first;
  for (std::size_t col = 0; col < table.header.size(); ++col) {
    const auto [at, fresh] = first.emplace(table.header[col], col);
    if (!fresh) {
      throw std::invalid_argument(
          fmt::format("{}:1: column {} ('{}'): the same name as column {}; column names must be unique",
                      table.path, col + 1, Abbreviated(table.header[col], 40), at->second + 1));
    }
  }
}

Columns ResolveColumns(const CsvTable& table, int state_size, const SampleDataOptions& options) {
  CheckUniqueNames(table);
  Columns c = NamedColumns(table, state_size, options.columns);
  if (c.run < 0) c.run = table.Find("run");
  c.j = table.Find("j");
  for (int* truth : {&c.map, &c.q}) {  // a state column or model state named so stays a state
    const std::string name = truth == &c.map ? "map" : "q";
    const auto& names = options.state_names;
    *truth = std::find(names.begin(), names.end(), name) != names.end() ? -1 : table.Find(name);
    if (std::find(c.state.begin(), c.state.end(), *truth) != c.state.end()) *truth = -1;
  }
  if (c.time < 0) c.time = c.run == 0 ? 1 : 0;  // the first column, after a leading run column
  if (!c.state.empty()) CheckDistinctColumns(table, c, options.columns);
  if (c.time >= static_cast<int>(table.header.size())) {
    throw std::invalid_argument(
        fmt::format("{}:1: only a run column; need time + {} state columns", table.path, state_size));
  }
  for (const std::string& name : options.inputs) {
    c.input.push_back(table.Find(name));
    if (c.input.back() < 0) {
      throw std::invalid_argument(
          fmt::format("{}:1: no column '{}' for the model's input of that name (the columns are {})",
                      table.path, Abbreviated(name, 40), fmt::join(table.header, ",")));
    }
    if (c.input.back() == c.time ||
        std::find(c.state.begin(), c.state.end(), c.input.back()) != c.state.end()) {
      throw std::invalid_argument(
          fmt::format("{}:1: SampleDataOptions::columns: column '{}' is the model's input '{}'; it cannot be "
                      "the time or a state as well",
                      table.path, Abbreviated(name, 40), Abbreviated(name, 40)));
    }
  }
  if (c.state.empty()) c.state = DefaultStateColumns(table, state_size, c, options.state_names);
  if (static_cast<int>(c.state.size()) < state_size) {
    throw std::invalid_argument(
        fmt::format("{}:1: {} columns ({}); need time + {} state columns for the model", table.path,
                    table.header.size(), fmt::join(table.header, ","), state_size));
  }
  return c;
}

std::string ColumnName(const CsvTable& table, int c) {
  return fmt::format("column {} ('{}')", c + 1, table.header[static_cast<std::size_t>(c)]);
}

// One data row: its cells in header order and its first line in its file.
struct RowView {
  std::span<const double> cells;
  long line = 0;
  double operator()(int col) const { return cells[static_cast<std::size_t>(col)]; }
};

// A time, state or input cell beyond ±kMaxMagnitude (false for NaN: a missing cell).
void CheckMagnitude(const CsvTable& table, int col, const RowView& cell) {
  if (std::abs(cell(col)) > kMaxMagnitude) {
    throw std::invalid_argument(fmt::format("{}:{}: {}: {} is out of range: |value| must be ≤ {:g} (rescale the data)",
                                            table.path, cell.line, ColumnName(table, col), cell(col), kMaxMagnitude));
  }
}

// Time, run and j cells, and the magnitude of state cells, of one row.
void CheckRow(const CsvTable& table, const Columns& c, const RowView& cell) {
  const long line = cell.line;
  if (std::isnan(cell(c.time))) {
    throw std::invalid_argument(
        fmt::format("{}:{}: {}: the time is missing", table.path, line, ColumnName(table, c.time)));
  }
  for (const std::vector<int>* cols : {&c.state, &c.input}) {
    for (int col : *cols) CheckMagnitude(table, col, cell);
  }
  CheckMagnitude(table, c.time, cell);
  if (c.run >= 0) {
    const double v = cell(c.run);
    if (!(v == std::floor(v)) || std::abs(v) > 1e15) {
      throw std::invalid_argument(fmt::format("{}:{}: {}: {} is not a run number (an integer)", table.path,
                                              line, ColumnName(table, c.run), v));
    }
  }
  if (c.j >= 0) {
    const double v = cell(c.j);
    if (v != std::floor(v) || v < 0 || v > static_cast<double>(std::numeric_limits<int>::max())) {
      throw std::invalid_argument(
          fmt::format("{}:{}: column {} ('j'): {} is not a jump count (an integer in [0, 2147483647])",
                      table.path, line, c.j + 1, v));
    }
  }
  for (const int col : {c.map, c.q}) {
    if (col < 0) continue;
    const double v = cell(col);
    if (v != std::floor(v) || v < -1 || v > 1e6) {
      throw std::invalid_argument(fmt::format("{}:{}: column {} ('{}'): {} is not an index (an integer in [-1, 1e6])",
                                              table.path, line, col + 1, table.header[std::size_t(col)], v));
    }
  }
}

// The ground-truth jump counter of one table: it never decreases within a run, and the runs are joined
// without a step (run r's counter continues from the last value of the runs before it, whatever
// value the run starts at), so a run boundary is never a true jump.
class JumpCounter {
 public:
  JumpCounter(const CsvTable& table, const Columns& c, const BlockArray<int>& joined)
      : table_(table), col_(c.j), joined_(joined) {}
  void StartRun(const RowView& row) {
    if (col_ < 0) return;
    offset_ = (joined_.empty() ? 0 : std::int64_t{joined_.back()}) - Cell(row);
  }
  // The row's counter does not fall below the run's row before it (`prev`; null at a run's start).
  void Check(const RowView& row, const RowView* prev) const {
    if (col_ < 0 || prev == nullptr || Cell(row) >= Cell(*prev)) return;
    throw std::invalid_argument(fmt::format(
        "{}:{}: column {} ('j'): {} after {} (line {}): a jump counter never decreases within a run",
        table_.path, row.line, col_ + 1, Cell(row), Cell(*prev), prev->line));
  }
  int Joined(const RowView& row) const {
    const std::int64_t v = offset_ + Cell(row);
    if (v > std::numeric_limits<int>::max()) {
      throw std::invalid_argument(
          fmt::format("{}:{}: column {} ('j'): the runs' jump counters add up to {}, beyond 2147483647",
                      table_.path, row.line, col_ + 1, v));
    }
    return static_cast<int>(v);
  }

 private:
  std::int64_t Cell(const RowView& row) const { return static_cast<std::int64_t>(row(col_)); }
  const CsvTable& table_;
  int col_;
  const BlockArray<int>& joined_;
  std::int64_t offset_ = 0;
};

// Steps within chains: their median, the gap rule, and whether the data are one uniform chain.
void CutGaps(const std::string& path, const SampleDataOptions& options, SampleData& d) {
  std::vector<double> steps;
  steps.reserve(d.t.size());
  for (std::size_t k = 1; k < d.t.size(); ++k) {
    if (!d.chain_start[k]) steps.push_back(d.t[k] - d.t[k - 1]);
  }
  if (steps.empty()) {
    throw std::invalid_argument(fmt::format("{}: no run has two samples", path));
  }
  const double mean = (d.t.back() - d.t.front()) / static_cast<double>(d.t.size() - 1);
  double worst = 0.0;
  for (double s : steps) worst = std::max(worst, std::abs(s - mean) / mean);
  std::nth_element(steps.begin(), steps.begin() + static_cast<long>(steps.size() / 2), steps.end());
  const double median = steps[steps.size() / 2];
  steps = {};
  d.max_gap = options.max_gap > 0.0 ? options.max_gap : kDefaultGapFactor * median;
  for (std::size_t k = 1; k < d.t.size(); ++k) {
    if (!d.chain_start[k] && d.t[k] - d.t[k - 1] > d.max_gap) {
      d.chain_start[k] = 1;
      ++d.gaps;
    }
  }
  d.uniform = d.run_names.size() == 1 && d.chains() == 1 && worst <= 1e-6;
  d.dt = d.uniform ? mean : median;
}

// A state column whose largest |value| is below kMinMagnitude (but not 0): its products underflow.
void CheckStateScale(const SampleData& d) {
  for (Eigen::Index i = 0; i < d.y.rows(); ++i) {
    const double largest = d.y.row(i).cwiseAbs().maxCoeff();
    if (largest > 0.0 && largest < kMinMagnitude) {
      throw std::invalid_argument(
          fmt::format("{}: column '{}': the largest |value| is {:g}, below {:g} (rescale the data)", d.path,
                      d.state_columns[static_cast<std::size_t>(i)], largest, kMinMagnitude));
    }
  }
}

// SampleData built table by table, each table row by row (a file need not be held whole): the
// per-sample arrays grow block by block as rows come (BlockArray: nothing copied, at most a block
// unused), and are moved into arrays of their exact size at the end, one at a time.
class SampleBuilder {
 public:
  SampleBuilder(int state_size, const SampleDataOptions& options) : n_(state_size), options_(options) {
    if (!(options.max_gap >= 0.0) || !std::isfinite(options.max_gap)) {
      throw std::invalid_argument(fmt::format(
          "SampleDataOptions::max_gap = {}: must be finite and >= 0 (0: the default)", options.max_gap));
    }
  }
  // A table's rows one by one: Begin with its path and header (no rows needed), Row for each data
  // row in file order, End after the last (`several`: more than one table is or will be added).
  void Begin(const CsvTable& head);
  void Row(const RowView& row);
  void End(bool several);
  // A table already read.
  void Add(const CsvTable& table, bool several) {
    Begin(table);
    std::vector<double> cells(table.columns.size());
    for (std::size_t r = 0; r < static_cast<std::size_t>(table.rows()); ++r) {
      for (std::size_t c = 0; c < cells.size(); ++c) cells[c] = table.columns[c][r];
      Row({cells, table.line_of_row[r]});
    }
    End(several);
  }
  SampleData Finish() &&;

 private:
  void StartRun(const RowView& row, long run);
  void CheckStep(const RowView& row) const;
  void Append(const RowView& row);

  int n_;
  const SampleDataOptions& options_;
  SampleData d_;
  std::vector<std::string> paths_;
  // The per-sample arrays as they grow (SampleData's t, y by columns, u by columns, j, map, q, run,
  // chain_start, line).
  BlockArray<double> t_, y_, u_;
  BlockArray<int> j_, map_, q_, run_;
  BlockArray<std::uint8_t> chain_start_;
  BlockArray<long> line_;
  bool all_j_ = true, all_map_ = true, all_q_ = true;
  // The table being read.
  CsvTable head_;
  Columns c_;
  std::optional<JumpCounter> counter_;
  std::map<long, int> seen_;      // run number -> its index in d_.run_names
  long current_ = 0;              // the run number of the row before
  int run_index_ = -1;            // its index (-1: no row yet)
  bool break_next_ = true;        // the next sample starts a chain
  std::vector<double> prev_;      // the row before (its cells) ...
  long prev_line_ = 0;            // ... and its line
  std::size_t samples_before_ = 0;
  long missing_before_ = 0;
};

void SampleBuilder::Begin(const CsvTable& head) {
  paths_.push_back(head.path);
  head_.path = head.path;
  head_.header = head.header;
  c_ = ResolveColumns(head_, n_, options_);
  all_j_ = all_j_ && c_.j >= 0;
  all_map_ = all_map_ && c_.map >= 0;
  all_q_ = all_q_ && c_.q >= 0;
  if (d_.state_columns.empty()) {
    for (int col : c_.state) d_.state_columns.push_back(head_.header[static_cast<std::size_t>(col)]);
  }
  if (d_.input_columns.empty()) {
    for (int col : c_.input) d_.input_columns.push_back(head_.header[static_cast<std::size_t>(col)]);
  }
  counter_.emplace(head_, c_, j_);
  seen_.clear();
  current_ = 0;
  run_index_ = -1;
  break_next_ = true;
  samples_before_ = t_.size();
  missing_before_ = d_.missing_rows;
}

void SampleBuilder::StartRun(const RowView& row, long run) {
  if (seen_.count(run)) {
    throw std::invalid_argument(
        fmt::format("{}:{}: {}: run {} appears again after run {}; the rows of a run must be contiguous",
                    head_.path, row.line, ColumnName(head_, c_.run), run, current_));
  }
  run_index_ = static_cast<int>(d_.run_names.size());
  seen_[run] = run_index_;
  d_.run_names.push_back(c_.run >= 0 ? fmt::format("{} run {}", head_.path, run) : head_.path);
  current_ = run;
  break_next_ = true;
  counter_->StartRun(row);
}

// Time increases from the row before (in the same run) by at least kMinStep.
void SampleBuilder::CheckStep(const RowView& row) const {
  const double t = row(c_.time), before = prev_[static_cast<std::size_t>(c_.time)];
  if (!(t > before)) {
    throw std::invalid_argument(fmt::format("{}:{}: {}: time {} is not after {} (line {}): time must increase",
                                            head_.path, row.line, ColumnName(head_, c_.time), t, before,
                                            prev_line_));
  }
  if (t - before < kMinStep) {
    throw std::invalid_argument(fmt::format("{}:{}: {}: the step {:g} after line {} is below {:g} s (rescale the time)",
                                            head_.path, row.line, ColumnName(head_, c_.time), t - before,
                                            prev_line_, kMinStep));
  }
}

// One row: checked, then appended as a sample, or counted as missing (the chain goes on across it:
// the gap rule judges the step over it).
void SampleBuilder::Row(const RowView& row) {
  CheckRow(head_, c_, row);
  const long run = c_.run >= 0 ? static_cast<long>(row(c_.run)) : 0;
  const bool same_run = run_index_ >= 0 && run == current_;
  if (same_run) {
    CheckStep(row);
  } else {
    StartRun(row, run);
  }
  const RowView prev{prev_, prev_line_};
  counter_->Check(row, same_run ? &prev : nullptr);
  bool missing = false;
  for (int col : c_.state) missing = missing || std::isnan(row(col));
  for (int col : c_.input) missing = missing || std::isnan(row(col));
  if (missing) {
    if (d_.missing_rows++ == 0) d_.first_missing_line = row.line;
    d_.missing.push_back({.run = run_index_, .line = row.line, .t = row(c_.time)});
  } else {
    Append(row);
  }
  prev_.assign(row.cells.begin(), row.cells.end());
  prev_line_ = row.line;
}

void SampleBuilder::Append(const RowView& row) {
  t_.push_back(row(c_.time));
  for (int col : c_.state) y_.push_back(row(col));
  for (int col : c_.input) u_.push_back(row(col));
  if (c_.j >= 0) j_.push_back(counter_->Joined(row));
  if (c_.map >= 0) map_.push_back(static_cast<int>(row(c_.map)));
  if (c_.q >= 0) q_.push_back(static_cast<int>(row(c_.q)));
  run_.push_back(run_index_);
  chain_start_.push_back(break_next_ ? 1 : 0);
  line_.push_back(row.line);
  break_next_ = false;
}

void SampleBuilder::End(bool several) {
  counter_.reset();
  if (t_.size() == samples_before_ && several) {  // one file of several is not left out silently
    const long rows = d_.missing_rows - missing_before_;
    throw std::invalid_argument(
        rows == 0 ? fmt::format("{}: no samples (no data rows)", head_.path)
                  : fmt::format("{}: no samples (each of its {} rows has a missing state value)", head_.path,
                                rows));
  }
}

SampleData SampleBuilder::Finish() && {
  d_.path = fmt::format("{}", fmt::join(paths_, ", "));
  const auto k = static_cast<long>(t_.size());
  CheckLimit(kMaxSamples, k, d_.path);
  if (k < 3) {
    throw std::invalid_argument(
        fmt::format("{}: {} samples{}; the identifier needs at least 3", d_.path, k,
                    d_.missing_rows ? fmt::format(" ({} {} with a missing value left out)", d_.missing_rows,
                                                  d_.missing_rows == 1 ? "row" : "rows")
                                    : ""));
  }
  d_.t = t_.Take();
  d_.chain_start = chain_start_.Take();
  d_.run = run_.Take();
  CutGaps(d_.path, options_, d_);
  d_.y.resize(n_, k);
  y_.MoveTo(d_.y.data());
  d_.u.resize(static_cast<Eigen::Index>(options_.inputs.size()), k);
  u_.MoveTo(d_.u.data());
  CheckStateScale(d_);
  d_.line = line_.Take();
  if (all_j_) d_.j = j_.Take();
  if (all_map_) d_.map = map_.Take();
  if (all_q_) d_.q = q_.Take();
  return std::move(d_);
}

}  // namespace

std::size_t SampleData::HeldBytes() const {
  return t.capacity() * sizeof(double) + static_cast<std::size_t>(y.size() + u.size()) * sizeof(double) +
         (j ? j->capacity() * sizeof(int) : 0) + run.capacity() * sizeof(int) + chain_start.capacity() +
         line.capacity() * sizeof(long);
}

SampleData SampleDataFromTables(const std::vector<CsvTable>& tables, int state_size,
                                const SampleDataOptions& options) {
  SampleBuilder builder(state_size, options);
  for (const CsvTable& table : tables) builder.Add(table, tables.size() > 1);
  return std::move(builder).Finish();
}

SampleData SampleDataFromTable(const CsvTable& table, int state_size) {
  return SampleDataFromTables({table}, state_size, {});
}

SampleData SampleDataFromArrays(const std::vector<std::vector<double>>& times, const std::vector<Mat>& y,
                                double dt, const SampleDataOptions& options) {
  if (times.size() != y.size() || y.empty()) {
    throw std::invalid_argument(fmt::format("{} runs of samples, {} of times", y.size(), times.size()));
  }
  std::vector<CsvTable> tables;
  std::int64_t samples = 0;  // within the limit before anything is copied
  for (const Mat& run : y) samples += run.cols();
  CheckLimit(kMaxSamples, samples, "y");
  for (std::size_t r = 0; r < y.size(); ++r) {
    CsvTable t;
    t.path = fmt::format("run {}", r + 1);
    const Eigen::Index k_count = y[r].cols();
    if (!times[r].empty() && static_cast<Eigen::Index>(times[r].size()) != k_count) {
      throw std::invalid_argument(fmt::format("{}: {} samples, {} times", t.path, k_count, times[r].size()));
    }
    if (times[r].empty() && (!(dt > 0.0) || !std::isfinite(dt))) {
      throw std::invalid_argument(fmt::format("{}: no times, and dt = {}: must be > 0", t.path, dt));
    }
    t.header.push_back("t");
    t.columns.emplace_back();
    for (Eigen::Index i = 0; i < y[r].rows(); ++i) {
      t.header.push_back(fmt::format("y{}", i + 1));
      t.columns.emplace_back(static_cast<std::size_t>(k_count));
      for (Eigen::Index k = 0; k < k_count; ++k) {
        const double v = y[r](i, k);
        if (std::isinf(v)) {  // as the CSV reader: infinite is refused, NaN is a missing cell
          throw std::invalid_argument(fmt::format("{}:{}: column {} ('{}'): '{}' is not finite", t.path,
                                                  k + 1, i + 2, t.header.back(), v));
        }
        t.columns.back()[static_cast<std::size_t>(k)] = v;
      }
    }
    for (Eigen::Index k = 0; k < k_count; ++k) {
      t.columns[0].push_back(times[r].empty() ? static_cast<double>(k) * dt
                                              : times[r][static_cast<std::size_t>(k)]);
      t.line_of_row.push_back(static_cast<long>(k) + 1);
    }
    tables.push_back(std::move(t));
  }
  return SampleDataFromTables(tables, static_cast<int>(y.front().rows()), options);
}

SampleData ReadSampleData(const std::vector<std::string>& paths, int state_size,
                          const SampleDataOptions& options) {
  SampleBuilder builder(state_size, options);
  CsvRowSink sink;  // each file streamed into the samples, never held whole
  sink.header = [&](const CsvTable& head) { builder.Begin(head); };
  sink.row = [&](std::span<const double> cells, long line) { builder.Row({cells, line}); };
  for (const std::string& p : paths) {
    ReadCsvRows(p, sink);
    builder.End(paths.size() > 1);
  }
  return std::move(builder).Finish();
}

SampleData ReadSampleData(const std::string& path, int state_size) {
  return ReadSampleData(std::vector<std::string>{path}, state_size, {});
}

namespace {

// Whether the steps between samples first − 1 … last are equal (within 1e-3 relative).
bool EqualSteps(const std::vector<double>& t, std::size_t first, std::size_t last) {
  const double step = t[first] - t[first - 1];
  for (std::size_t i = first; i <= last; ++i) {
    if (std::abs((t[i] - t[i - 1]) - step) > 1e-3 * step) return false;
  }
  return true;
}

// Whether the steps from sample k − 2 to k + 2 are within kOutlierStepRatio of each other (a row or
// two missing between samples, not a gap).
bool SimilarSteps(const std::vector<double>& t, std::size_t k) {
  double lo = t[k] - t[k - 1], hi = lo;
  for (std::size_t i = k - 1; i <= k + 2; ++i) {
    lo = std::min(lo, t[i] - t[i - 1]);
    hi = std::max(hi, t[i] - t[i - 1]);
  }
  return hi <= kOutlierStepRatio * lo;
}

// Keeps the samples whose `keep` is 1 in every per-sample array.
template <class T>
void KeepSamples(const std::vector<std::uint8_t>& keep, std::vector<T>* v) {
  std::size_t to = 0;
  for (std::size_t k = 0; k < v->size(); ++k) {
    if (keep[k]) (*v)[to++] = (*v)[k];
  }
  v->resize(to);
}

Mat KeepColumns(const std::vector<std::uint8_t>& keep, const Mat& m) {
  if (m.cols() == 0) return m;
  std::vector<Eigen::Index> cols;
  for (std::size_t k = 0; k < keep.size(); ++k) {
    if (keep[k]) cols.push_back(static_cast<Eigen::Index>(k));
  }
  return m(Eigen::all, cols);
}

}  // namespace

void LeaveOutOutliers(SampleData* data) {
  SampleData& d = *data;
  const auto K = static_cast<std::size_t>(d.y.cols());
  std::vector<std::uint8_t> keep(K, 1);
  std::vector<OutlierSample> found;
  // The chains [begin, end) in order.
  std::vector<std::pair<std::size_t, std::size_t>> chains;
  for (std::size_t begin = 0; begin < K;) {
    std::size_t end = begin + 1;
    while (end < K && !d.chain_start[end]) ++end;
    chains.emplace_back(begin, end);
    begin = end;
  }
  // d of state r at sample k (1 ≤ k − begin, k + 1 < end): on unequal steps h1 = t_k − t_{k−1},
  // h2 = t_{k+1} − t_k (a row missing beside k), twice the line through the neighbours at t_k less
  // y_k, 2 (h2 y_{k−1} + h1 y_{k+1}) / (h1 + h2) − 2 y_k, which is d on equal steps.
  const auto second = [&](Eigen::Index r, std::size_t k) {
    const double h1 = d.t[k] - d.t[k - 1], h2 = d.t[k + 1] - d.t[k];
    const double before = d.y(r, Eigen::Index(k - 1)), at = d.y(r, Eigen::Index(k)),
                 after = d.y(r, Eigen::Index(k + 1));
    if (std::abs(h2 - h1) <= 1e-3 * h1) return after - 2.0 * at + before;
    return 2.0 * (h2 * before + h1 * after) / (h1 + h2) - 2.0 * at;
  };
  // d's robust sd per state, over every chain (one noise level per measured state, as the fit has).
  Vec sds(d.y.rows());
  for (Eigen::Index r = 0; r < d.y.rows(); ++r) {
    std::vector<double> all;
    for (const auto& [begin, end] : chains) {
      for (std::size_t k = begin + 1; k + 1 < end; ++k) all.push_back(second(r, k));
    }
    sds[r] = all.size() >= 2 ? std::sqrt(6.0) * NoiseSigmaFromSecondDifferences(all) : 0.0;
  }
  const auto leave_out = [&](std::size_t k, Eigen::Index r, double dk) {
    keep[k] = 0;
    found.push_back({.run = d.run[k],
                     .line = d.line[k],
                     .t = d.t[k],
                     .row = static_cast<int>(r),
                     .value = d.y(r, Eigen::Index(k)),
                     .sds = std::abs(dk) / sds[r]});
  };
  for (const auto& [begin, end] : chains) {
    for (Eigen::Index r = 0; r < d.y.rows() && end - begin >= 12; ++r) {
      std::vector<double> dd(end - begin - 2);  // dd[i]: d at sample begin + 1 + i
      for (std::size_t k = begin + 1; k + 1 < end; ++k) dd[k - begin - 1] = second(r, k);
      const double sd = sds[r];
      if (!(sd > 0.0)) continue;
      for (std::size_t k = begin + 2; k + 3 <= end; ++k) {
        const double c = dd[k - begin - 1], before = dd[k - begin - 2], after = dd[k - begin];
        // A neighbour's d holds away / (away + next) of a displaced sample's, of the other sign (its two
        // steps: away from sample k, next to it); ± 0.25 of |d_k| is left to the noise.
        const auto share = [c](double v, double away, double next) {
          const double expected = std::abs(away - next) <= 1e-3 * next ? 0.5 : away / (away + next);
          return v * c < 0.0 && std::abs(v) >= (expected - 0.25) * std::abs(c) &&
                 std::abs(v) <= (expected + 0.25) * std::abs(c);
        };
        if (std::abs(c) <= kOutlierSds * sd || !SimilarSteps(d.t, k) ||
            !share(before, d.t[k - 1] - d.t[k - 2], d.t[k] - d.t[k - 1]) ||
            !share(after, d.t[k + 2] - d.t[k + 1], d.t[k + 1] - d.t[k]) || !keep[k])
          continue;
        leave_out(k, r, c);
      }
      // Two neighbours displaced by δ1, δ2 of one sign: d = (δ1, δ2 − 2δ1, δ1 − 2δ2, δ2) at k − 1 … k + 2.
      for (std::size_t k = begin + 2; k + 4 <= end; ++k) {
        const double p = dd[k - begin - 2], a = dd[k - begin - 1], b = dd[k - begin], q = dd[k - begin + 1];
        const double size = std::max(std::abs(a), std::abs(b)), slack = 0.25 * size;
        if (std::abs(a) <= kOutlierSds * sd || std::abs(b) <= kOutlierSds * sd || a * b <= 0.0 || p * a >= 0.0 ||
            q * a >= 0.0 || std::abs(a - (q - 2.0 * p)) > slack || std::abs(b - (p - 2.0 * q)) > slack ||
            !keep[k] || !keep[k + 1] || !EqualSteps(d.t, k - 1, k + 3))
          continue;
        leave_out(k, r, a);
        leave_out(k + 1, r, b);
      }
    }
  }
  if (found.empty()) return;
  std::sort(found.begin(), found.end(), [](const OutlierSample& a, const OutlierSample& b) {
    return std::pair(a.run, a.line) < std::pair(b.run, b.line);
  });
  d.y = KeepColumns(keep, d.y);
  d.u = KeepColumns(keep, d.u);
  KeepSamples(keep, &d.t);
  for (auto* v : {&d.j, &d.map, &d.q}) {
    if (*v) KeepSamples(keep, &**v);
  }
  KeepSamples(keep, &d.run);
  KeepSamples(keep, &d.chain_start);
  KeepSamples(keep, &d.line);
  d.uniform = false;
  d.outliers = std::move(found);
}

}  // namespace hysid
