// The tables of a finished sweep, all computed from the unit rows alone (so a merge of shards writes
// exactly what an unsharded run writes):
//   trials.csv   the rows sorted by unit id, without the wall time;
//   timings.csv  unit, cell, trial, wall_ms (varies from run to run, hence kept apart);
//   summary.csv  one row per cell (the cells summarised in parallel on TBB's current concurrency, each
//                from its own rows only, written in cell order): its keys, n (trials), failures, and for each metric of
//                SummaryMetrics() over the rows with status ok: mean, median, std (n − 1), and the 95 %
//                confidence interval of the mean inside the metric's range (MetricRangeOf, intervals.hpp;
//                empty when n < 2): a rate's Wilson interval, a non-negative metric's percentile bootstrap.
//                With the refine axis also crlb_fit_e_alpha, crlb_fit_e_beta (the mean over the ok rows of
//                the bound over the samples each estimate used) and efficiency_fit_alpha,
//                efficiency_fit_beta (the mean errors over them), and per cover_NAME column of trials.csv
//                cover_NAME_n (trials with a reported interval), _mean (the share covering the truth)
//                and its Wilson score interval _ci95_lo, _ci95_hi (z = 1.96, at n; empty when n = 0).
//                With a baseline ([summary] baseline): the baseline's cell, and for each metric the
//                paired differences cell − baseline over the trials where both have a value: their
//                count, mean and 95 % interval mean ± t(0.975, n − 1)·std/√n (a difference can be < 0).
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace hysid {

class BootstrapPlans;

// The journal's columns: trials.csv's plus a last "wall_ms".
std::vector<std::string> JournalHeader(const std::vector<std::string>& trial_header);

// A baseline: per-cell key columns of trials.csv and their values (SweepConfig::baseline).
using Baseline = std::vector<std::pair<std::string, std::string>>;

// The baseline cell of each cell, given the cells' keys (`cell_keys[i]` in the order of `key_names`):
// the one cell whose keys equal cell i's with the baseline's keys set to its values, where a key the
// baseline does not name matches anything when it is empty in either cell (an axis one of the two
// detectors does not use). −1 when no cell matches, −2 when several do.
std::vector<long> MatchBaselines(const std::vector<std::string>& key_names,
                                 const std::vector<std::vector<std::string>>& cell_keys,
                                 const Baseline& baseline);

// The key columns MatchBaselines compares (trials.csv names).
const std::vector<std::string>& BaselineKeyNames();

// rows: unit id → journal cells. Files are written under temporary names and renamed.
void WriteSweepTables(const std::filesystem::path& dir, const std::vector<std::string>& trial_header,
                      const std::map<long, std::vector<std::string>>& rows, const Baseline& baseline = {});

// Reads a trials.csv back (header and rows by unit id); errors name the file and line.
void ReadTrialsCsv(const std::filesystem::path& path, std::vector<std::string>* header,
                   std::map<long, std::vector<std::string>>* rows);

// The values a metric takes, which its interval respects: any real (the t-interval), [0, ∞) (the
// percentile bootstrap) or [0, 1] (the Wilson interval at the effective sample size).
enum class MetricRange { kReal, kNonNegative, kUnitInterval };

// The range of a summary metric (SummaryMetrics() and the rel_err_* columns): kUnitInterval for the rates
// misclassification, precision, recall and flow_outside_share, kNonNegative for the other metrics
// (counts, errors, distances); logic_error for a name that is not a summary metric.
MetricRange MetricRangeOf(const std::string& metric);

struct MetricSummary {
  long n = 0;
  double mean, median, std, ci_lo, ci_hi;  // NaN when undefined
};
// The statistics of `values`; with `plans`, a non-negative metric's bootstrap takes its draws from
// them (the same bounds).
MetricSummary Summarize(std::vector<double> values, MetricRange range = MetricRange::kReal,
                        BootstrapPlans* plans = nullptr);

}  // namespace hysid
