#include "experiments/sweep/tables.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>
#include <oneapi/tbb/parallel_for.h>

#include "core/detectors/detector.hpp"
#include "core/estimators/estimator.hpp"
#include "core/io/csv.hpp"
#include "core/io/limits.hpp"
#include "core/stats/quantiles.hpp"
#include "experiments/sweep/intervals.hpp"
#include "experiments/sweep/journal.hpp"
#include "experiments/sweep/trial.hpp"

namespace hysid {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kWilsonZ95 = 1.959963984540054;  // the coverage's Wilson interval: two-sided 95 %

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
    throw std::invalid_argument(fmt::format("the row of unit {}: column '{}': '{}' is not a number", unit,
                                            column, Abbreviated(text)));
  }
  return v;
}

}  // namespace

std::vector<std::string> JournalHeader(const std::vector<std::string>& trial_header) {
  std::vector<std::string> h = trial_header;
  h.push_back("wall_ms");
  return h;
}

namespace {

// The metrics of a sweep of hybrid automata (trial.hpp): event counts, the event-time errors in
// samples (detected, fitted), e_beta_MAP and crlb_e_beta_MAP.
bool IsAutomatonMetric(const std::string& h) {
  for (const char* name : {"events_wrong_map", "events_missed", "events_spurious", "event_time_error",
                           "event_time_error_fitted"}) {
    if (h == name) return true;
  }
  return h.rfind("e_beta_", 0) == 0 || h.rfind("crlb_e_beta_", 0) == 0;
}

}  // namespace

MetricRange MetricRangeOf(const std::string& metric) {
  for (const char* rate : {"misclassification", "precision", "recall", "flow_outside_share"}) {
    if (metric == rate) return MetricRange::kUnitInterval;
  }
  if (metric.rfind(kCoveragePrefix, 0) == 0) return MetricRange::kUnitInterval;
  const auto& core = SummaryMetrics();
  if (std::find(core.begin(), core.end(), metric) != core.end() || metric == "e_gamma" ||
      metric.rfind(kRelativeErrorPrefix, 0) == 0 || IsAutomatonMetric(metric))
    return MetricRange::kNonNegative;
  throw std::logic_error(fmt::format("'{}' is not a summary metric", metric));
}

MetricSummary Summarize(std::vector<double> v, MetricRange range, BootstrapPlans* plans) {
  MetricSummary s{static_cast<long>(v.size()), kNaN, kNaN, kNaN, kNaN, kNaN};
  if (v.empty()) return s;
  std::array<double, 2> ci{kNaN, kNaN};
  if (range == MetricRange::kUnitInterval) ci = RateInterval(v);
  if (range == MetricRange::kNonNegative)
    ci = plans != nullptr ? plans->MeanInterval(v) : BootstrapMeanInterval(v);
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
    if (range == MetricRange::kReal) ci = {s.mean - half, s.mean + half};
  }
  s.ci_lo = ci[0];
  s.ci_hi = ci[1];
  return s;
}

const std::vector<std::string>& BaselineKeyNames() {
  // The order of SweepCell's keys: model, δt, σ, the sweepable options (estimators' then detectors', as
  // SweepGrid::options), estimator, detector, refine (empty without a refine axis).
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n{"model", "dt", "sigma"};
    for (const auto& o : EstimatorOptions()) {
      if (o.sweepable) n.emplace_back(o.name);
    }
    for (const auto& o : DetectorOptions()) {
      if (o.sweepable) n.emplace_back(o.name);
    }
    n.insert(n.end(), {"estimator", "detector", "refine"});
    return n;
  }();
  return names;
}

std::vector<long> MatchBaselines(const std::vector<std::string>& key_names,
                                 const std::vector<std::vector<std::string>>& cell_keys,
                                 const Baseline& baseline) {
  std::vector<const std::string*> named(key_names.size(), nullptr);
  for (const auto& [k, v] : baseline) {
    const auto it = std::find(key_names.begin(), key_names.end(), k);
    if (it == key_names.end()) throw std::logic_error(fmt::format("baseline key '{}' is not a cell key", k));
    named[static_cast<std::size_t>(it - key_names.begin())] = &v;
  }
  std::vector<long> out(cell_keys.size(), -1);
  for (std::size_t c = 0; c < cell_keys.size(); ++c) {
    for (std::size_t b = 0; b < cell_keys.size(); ++b) {
      bool match = true;
      for (std::size_t k = 0; match && k < key_names.size(); ++k) {
        const std::string& mine = cell_keys[c][k];
        const std::string& theirs = cell_keys[b][k];
        if (named[k] != nullptr) {
          match = theirs == *named[k];
        } else {
          match = mine == theirs || mine.empty() || theirs.empty();
        }
      }
      if (match) out[c] = out[c] == -1 ? static_cast<long>(b) : -2;
    }
  }
  return out;
}

namespace {

// One cell's rows: its keys, counts, and each trial's metric values (NaN: none).
struct CellRows {
  std::vector<std::string> keys;   // the summary's key columns
  std::vector<std::string> match;  // BaselineKeyNames() columns
  long n = 0, failures = 0;
  std::map<long, std::vector<double>> values;  // trial → one value per metric
  std::array<double, 3> crlb{0.0, 0.0, 0.0};   // Σ crlb_e_alpha, crlb_e_beta (crlb_e_gamma) over the rows with one
  long crlb_n = 0;
  // Σ crlb_fit_e_alpha, crlb_fit_e_beta (crlb_fit_e_gamma) over the ok rows with one.
  std::array<double, 3> crlb_fit{0.0, 0.0, 0.0};
  long crlb_fit_n = 0;
};

bool Has(const std::vector<std::string>& header, const std::string& name) {
  return std::find(header.begin(), header.end(), name) != header.end();
}

// Adds the row's crlb_e_alpha, crlb_e_beta and, with unknown guard parameters, crlb_e_gamma (when the
// table has them and they are not empty).
void AddCrlb(const std::vector<std::string>& header, const std::vector<std::string>& cells, CellRows* c) {
  if (!Has(header, "crlb_e_alpha")) return;
  const bool gamma = Has(header, "crlb_e_gamma");
  const std::string& a = cells[static_cast<std::size_t>(Column(header, "crlb_e_alpha"))];
  const std::string& b = cells[static_cast<std::size_t>(Column(header, "crlb_e_beta"))];
  const std::string g = gamma ? cells[static_cast<std::size_t>(Column(header, "crlb_e_gamma"))] : "0";
  if (a.empty() || b.empty() || g.empty()) return;
  c->crlb[0] += std::stod(a);
  c->crlb[1] += std::stod(b);
  c->crlb[2] += std::stod(g);
  ++c->crlb_n;
}

// Adds the ok row's crlb_fit_e_alpha, crlb_fit_e_beta (crlb_fit_e_gamma) when the table has them and they
// are not empty.
void AddFitCrlb(const std::vector<std::string>& header, const std::vector<std::string>& cells, CellRows* c) {
  if (!Has(header, "crlb_fit_e_alpha")) return;
  const bool gamma = Has(header, "crlb_fit_e_gamma");
  std::array<std::string, 3> v;
  for (int i = 0; i < (gamma ? 3 : 2); ++i) {
    static const char* const names[] = {"crlb_fit_e_alpha", "crlb_fit_e_beta", "crlb_fit_e_gamma"};
    v[static_cast<std::size_t>(i)] = cells[static_cast<std::size_t>(Column(header, names[i]))];
    if (v[static_cast<std::size_t>(i)].empty()) return;
  }
  for (std::size_t i = 0; i < 3; ++i) c->crlb_fit[i] += v[i].empty() ? 0.0 : std::stod(v[i]);
  ++c->crlb_fit_n;
}

// crlb_e_alpha, crlb_e_beta (the mean over the cell's rows; equal unless x0 is drawn per trial) and
// efficiency_alpha, efficiency_beta = e_alpha_mean / crlb_e_alpha, … (empty without a bound); with
// unknown guard parameters (`gamma`) then crlb_e_gamma and efficiency_gamma.
// With `fit`, the same of crlb_fit_* over the cell's ok rows (the bound over the samples each estimate
// used): crlb_fit_e_alpha, crlb_fit_e_beta, efficiency_fit_alpha, efficiency_fit_beta, ….
std::vector<std::string> EfficiencyCells(const CellRows& c, double e_alpha_mean, double e_beta_mean,
                                         bool gamma, double e_gamma_mean, bool fit = false) {
  const std::array<double, 3>& sum = fit ? c.crlb_fit : c.crlb;
  const long n = fit ? c.crlb_fit_n : c.crlb_n;
  if (n == 0) return std::vector<std::string>(gamma ? 6 : 4);
  const auto mean = [&](int i) { return sum[static_cast<std::size_t>(i)] / static_cast<double>(n); };
  const auto ratio = [](double e, double bound) {
    return bound > 0 && !std::isnan(e) ? FormatNumber(e / bound) : std::string();
  };
  std::vector<std::string> out{FormatNumber(mean(0)), FormatNumber(mean(1)), ratio(e_alpha_mean, mean(0)),
                               ratio(e_beta_mean, mean(1))};
  if (gamma) out.insert(out.end(), {FormatNumber(mean(2)), ratio(e_gamma_mean, mean(2))});
  return out;
}

std::vector<CellRows> CollectCells(const std::vector<std::string>& header,
                                   const std::map<long, std::vector<std::string>>& rows,
                                   const std::vector<std::string>& keys,
                                   const std::vector<std::string>& metrics) {
  std::vector<long> key_col, match_col, metric_col;
  for (const auto& k : keys) key_col.push_back(Column(header, k));
  for (const auto& k : BaselineKeyNames())
    match_col.push_back(k == "refine" && !Has(header, k) ? -1 : Column(header, k));
  for (const auto& m : metrics) metric_col.push_back(Column(header, m));
  const auto cell_col = static_cast<std::size_t>(Column(header, "cell"));
  const auto trial_col = static_cast<std::size_t>(Column(header, "trial"));
  const auto status_col = static_cast<std::size_t>(Column(header, "status"));
  std::vector<CellRows> out;
  // Rows are sorted by unit = cell·trials + trial, so each cell's rows are contiguous.
  for (auto it = rows.begin(); it != rows.end();) {
    const std::string cell = it->second[cell_col];
    CellRows c;
    for (long k : key_col) c.keys.push_back(it->second[static_cast<std::size_t>(k)]);
    for (long k : match_col)
      c.match.push_back(k < 0 ? std::string() : it->second[static_cast<std::size_t>(k)]);
    for (; it != rows.end() && it->second[cell_col] == cell; ++it) {
      const auto& cells = it->second;
      ++c.n;
      AddCrlb(header, cells, &c);
      if (cells[status_col] != kTrialOk) {
        ++c.failures;
        continue;
      }
      AddFitCrlb(header, cells, &c);
      std::vector<double>& v = c.values[std::stol(cells[trial_col])];
      for (std::size_t m = 0; m < metric_col.size(); ++m) {
        const std::string& text = cells[static_cast<std::size_t>(metric_col[m])];
        v.push_back(text.empty() ? kNaN : MetricValue(text, it->first, metrics[m]));
      }
    }
    out.push_back(std::move(c));
  }
  return out;
}

// The summary's key columns: "cell" and the trial columns from "model" to "detector" (dt, σ, the option
// axes, ...) or to "refine" when the sweep has that axis.
std::vector<std::string> SummaryKeys(const std::vector<std::string>& trial_header) {
  std::vector<std::string> keys{"cell"};
  const auto model_col = static_cast<std::size_t>(Column(trial_header, "model"));
  const auto last_col =
      static_cast<std::size_t>(Column(trial_header, Has(trial_header, "refine") ? "refine" : "detector"));
  keys.insert(keys.end(), trial_header.begin() + static_cast<long>(model_col),
              trial_header.begin() + static_cast<long>(last_col) + 1);
  return keys;
}

// The metrics summary.csv aggregates: SummaryMetrics(), then e_gamma when the trials table has it and
// the per-parameter rel_err_* columns, then a hybrid automaton's event and per-map metrics (the
// statistics of all these come last, after the baseline and efficiency columns).
std::vector<std::string> CellMetrics(const std::vector<std::string>& trial_header) {
  std::vector<std::string> metrics = SummaryMetrics();
  if (Has(trial_header, "e_gamma")) metrics.push_back("e_gamma");
  for (const std::string& h : trial_header) {
    if (h.rfind(kRelativeErrorPrefix, 0) == 0) metrics.push_back(h);
  }
  for (const std::string& h : trial_header) {
    if (IsAutomatonMetric(h)) metrics.push_back(h);
  }
  for (const std::string& h : trial_header) {
    if (h.rfind(kCoveragePrefix, 0) == 0) metrics.push_back(h);
  }
  return metrics;
}

// The number of coverage columns (cover_*) among the metrics: they come last.
std::size_t CoverageCount(const std::vector<std::string>& metrics) {
  return static_cast<std::size_t>(std::count_if(metrics.begin(), metrics.end(), [](const std::string& m) {
    return m.rfind(kCoveragePrefix, 0) == 0;
  }));
}

constexpr std::array<const char*, 5> kStats{"mean", "median", "std", "ci95_lo", "ci95_hi"};
// A coverage column's statistics: the trials with an interval, the share covering the truth and its
// Wilson score interval.
constexpr std::array<const char*, 4> kCoverageStats{"n", "mean", "ci95_lo", "ci95_hi"};

std::vector<std::string> SummaryHeader(const std::vector<std::string>& keys,
                                       const std::vector<std::string>& metrics, bool baseline,
                                       bool efficiency, bool gamma, bool fit) {
  const std::size_t n_core = SummaryMetrics().size();
  const std::size_t n_plain = metrics.size() - CoverageCount(metrics);
  std::vector<std::string> header = keys;
  header.insert(header.end(), {"trials", "failures"});
  for (std::size_t m = 0; m < n_core; ++m) {
    for (const char* stat : kStats) header.push_back(metrics[m] + "_" + stat);
  }
  if (baseline) {
    header.push_back("baseline_cell");
    for (std::size_t m = 0; m < n_core; ++m) {
      for (const char* stat : {"diff_n", "diff_mean", "diff_ci95_lo", "diff_ci95_hi"})
        header.push_back(metrics[m] + "_" + stat);
    }
  }
  if (efficiency)
    header.insert(header.end(), {"crlb_e_alpha", "crlb_e_beta", "efficiency_alpha", "efficiency_beta"});
  if (efficiency && gamma) header.insert(header.end(), {"crlb_e_gamma", "efficiency_gamma"});
  if (fit) {
    header.insert(header.end(),
                  {"crlb_fit_e_alpha", "crlb_fit_e_beta", "efficiency_fit_alpha", "efficiency_fit_beta"});
    if (gamma) header.insert(header.end(), {"crlb_fit_e_gamma", "efficiency_fit_gamma"});
  }
  for (std::size_t m = n_core; m < n_plain; ++m) {
    for (const char* stat : kStats) header.push_back(metrics[m] + "_" + stat);
  }
  for (std::size_t m = n_plain; m < metrics.size(); ++m) {
    for (const char* stat : kCoverageStats) header.push_back(metrics[m] + "_" + stat);
  }
  return header;
}

// The statistics of metric m (named `name`) over the cell's trials with a value.
MetricSummary MetricOf(const CellRows& c, std::size_t m, const std::string& name, BootstrapPlans* plans) {
  std::vector<double> v;
  for (const auto& [trial, values] : c.values) {
    if (!std::isnan(values[m])) v.push_back(values[m]);
  }
  return Summarize(std::move(v), MetricRangeOf(name), plans);
}

void AppendStats(const MetricSummary& s, std::vector<std::string>* out) {
  for (double x : {s.mean, s.median, s.std, s.ci_lo, s.ci_hi}) out->push_back(FormatNumber(x));
}

// Coverage column m of the cell: n (trials with a 0/1 value), the share of 1s and its Wilson score
// interval at n with z = 1.96 (empty when n = 0).
void AppendCoverage(const CellRows& c, std::size_t m, std::vector<std::string>* out) {
  long n = 0, covered = 0;
  for (const auto& [trial, values] : c.values) {
    if (std::isnan(values[m])) continue;
    ++n;
    covered += values[m] > 0.5 ? 1 : 0;
  }
  out->push_back(fmt::format("{}", n));
  if (n == 0) {
    out->insert(out->end(), 3, std::string());
    return;
  }
  const double p = static_cast<double>(covered) / static_cast<double>(n);
  const std::array<double, 2> ci = WilsonInterval(p, static_cast<double>(n), kWilsonZ95);
  for (double x : {p, ci[0], ci[1]}) out->push_back(FormatNumber(x));
}

// The baseline cell and the paired differences cell − baseline of each of the first n_metrics metrics.
void AppendBaselineDiffs(const CellRows& c, const CellRows* b, std::size_t n_metrics,
                         std::vector<std::string>* out) {
  out->push_back(b != nullptr ? b->keys[0] : std::string());
  for (std::size_t m = 0; m < n_metrics; ++m) {
    std::vector<double> d;
    for (const auto& [trial, values] : c.values) {
      const auto bt = b != nullptr ? b->values.find(trial) : c.values.end();
      if (b == nullptr || bt == b->values.end()) continue;
      if (!std::isnan(values[m]) && !std::isnan(bt->second[m])) d.push_back(values[m] - bt->second[m]);
    }
    const MetricSummary s = Summarize(std::move(d));
    out->push_back(b != nullptr ? fmt::format("{}", s.n) : std::string());
    for (double x : {s.mean, s.ci_lo, s.ci_hi}) out->push_back(FormatNumber(x));
  }
}

void WriteTrialAndTimingTables(const std::filesystem::path& dir, const std::vector<std::string>& trial_header,
                               const std::map<long, std::vector<std::string>>& rows) {
  const std::size_t nt = trial_header.size();
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

// What summary.csv holds besides the keys: the metrics (the first n_core of them before the baseline and
// efficiency columns), the baseline's paired differences, the efficiency columns (γ's too).
struct SummaryLayout {
  const std::vector<std::string>& metrics;
  std::size_t n_core;
  bool baseline, efficiency, gamma, fit;
  std::size_t n_plain;  // the metrics before the coverage columns
};

// Cell c's row of summary.csv; `b` its baseline cell (null: none).
std::vector<std::string> SummaryRow(const CellRows& c, const CellRows* b, const SummaryLayout& layout,
                                    BootstrapPlans* plans) {
  const std::vector<std::string>& metrics = layout.metrics;
  std::vector<std::string> out = c.keys;
  out.push_back(fmt::format("{}", c.n));
  out.push_back(fmt::format("{}", c.failures));
  std::vector<MetricSummary> stats;
  for (std::size_t m = 0; m < layout.n_plain; ++m) stats.push_back(MetricOf(c, m, metrics[m], plans));
  for (std::size_t m = 0; m < layout.n_core; ++m) AppendStats(stats[m], &out);
  if (layout.baseline) AppendBaselineDiffs(c, b, layout.n_core, &out);
  if (layout.efficiency) {
    const auto mean_of = [&](const char* name) {
      return stats[static_cast<std::size_t>(Column(metrics, name))].mean;
    };
    const std::vector<std::string> e = EfficiencyCells(c, mean_of("e_alpha"), mean_of("e_beta"), layout.gamma,
                                                       layout.gamma ? mean_of("e_gamma") : kNaN);
    out.insert(out.end(), e.begin(), e.end());
    if (layout.fit) {
      const std::vector<std::string> f =
          EfficiencyCells(c, mean_of("e_alpha"), mean_of("e_beta"), layout.gamma,
                          layout.gamma ? mean_of("e_gamma") : kNaN, true);
      out.insert(out.end(), f.begin(), f.end());
    }
  }
  for (std::size_t m = layout.n_core; m < layout.n_plain; ++m) AppendStats(stats[m], &out);
  for (std::size_t m = layout.n_plain; m < metrics.size(); ++m) AppendCoverage(c, m, &out);
  return out;
}

}  // namespace

void WriteSweepTables(const std::filesystem::path& dir, const std::vector<std::string>& trial_header,
                      const std::map<long, std::vector<std::string>>& rows, const Baseline& baseline) {
  WriteTrialAndTimingTables(dir, trial_header, rows);
  const std::vector<std::string> keys = SummaryKeys(trial_header);
  const bool efficiency = Has(trial_header, "crlb_e_alpha"), gamma = Has(trial_header, "crlb_e_gamma");
  const bool fit = efficiency && Has(trial_header, "crlb_fit_e_alpha");
  const std::vector<std::string> metrics = CellMetrics(trial_header);
  const std::size_t n_core = SummaryMetrics().size();
  const std::vector<CellRows> cells = CollectCells(trial_header, rows, keys, metrics);
  std::vector<long> base;
  if (!baseline.empty()) {
    std::vector<std::vector<std::string>> match;
    for (const CellRows& c : cells) match.push_back(c.match);
    base = MatchBaselines(BaselineKeyNames(), match, baseline);
  }
  const SummaryLayout layout{metrics, n_core, !baseline.empty(), efficiency, gamma, fit,
                             metrics.size() - CoverageCount(metrics)};
  // Each cell's row depends on its own rows (and its baseline's) only: summarised in parallel, written
  // in order.
  std::vector<std::vector<std::string>> out(cells.size());
  BootstrapPlans plans;
  tbb::parallel_for(std::size_t{0}, cells.size(), [&](std::size_t ci) {
    const CellRows* b = nullptr;
    if (layout.baseline && base[ci] >= 0) b = &cells[static_cast<std::size_t>(base[ci])];
    out[ci] = SummaryRow(cells[ci], b, layout, &plans);
  });
  CsvWriter summary(dir / "summary.csv",
                    SummaryHeader(keys, metrics, !baseline.empty(), efficiency, gamma, fit));
  for (const auto& row : out) summary.TextRow(row);
  summary.Commit();
}

void ReadTrialsCsv(const std::filesystem::path& path, std::vector<std::string>* header,
                   std::map<long, std::vector<std::string>>* rows) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument(fmt::format("{}: cannot open", path.string()));
  long line_no = 0;
  std::vector<std::string> cells;
  while (ReadCsvRecord(in, path.string(), &line_no, &cells)) {
    if (header->empty()) {
      *header = std::move(cells);
      continue;
    }
    if (cells.size() != header->size()) {
      throw std::invalid_argument(
          fmt::format("{}:{}: {} cells, expected {}", path.string(), line_no, cells.size(), header->size()));
    }
    long unit = 0;
    const auto [end, ec] = std::from_chars(cells[0].data(), cells[0].data() + cells[0].size(), unit);
    if (ec != std::errc() || end != cells[0].data() + cells[0].size() || unit < 0) {
      throw std::invalid_argument(fmt::format("{}:{}: column 1 ('unit'): '{}' is not a unit id",
                                              path.string(), line_no, Abbreviated(cells[0])));
    }
    if (!rows->emplace(unit, std::move(cells)).second) {
      throw std::invalid_argument(fmt::format("{}:{}: unit {} appears twice", path.string(), line_no, unit));
    }
  }
  if (line_no == 0) throw std::invalid_argument(fmt::format("{}: empty file", path.string()));
}

}  // namespace hysid
