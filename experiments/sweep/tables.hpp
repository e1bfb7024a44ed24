// The tables of a finished sweep, all computed from the unit rows alone (so a merge of shards writes
// exactly what an unsharded run writes):
//   trials.csv   the rows sorted by unit id, without the wall time;
//   timings.csv  unit, cell, trial, wall_ms (varies from run to run, hence kept apart);
//   summary.csv  one row per cell: its keys, n (trials), failures, and for each metric of
//                SummaryMetrics() over the rows with status ok: mean, median, std (n − 1), and the 95 %
//                confidence interval of the mean, mean ± t(0.975, n − 1)·std/√n (empty when n < 2).
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace hysid {

// The journal's columns: trials.csv's plus a last "wall_ms".
std::vector<std::string> JournalHeader(const std::vector<std::string>& trial_header);

// rows: unit id → journal cells. Files are written under temporary names and renamed.
void WriteSweepTables(const std::filesystem::path& dir, const std::vector<std::string>& trial_header,
                      const std::map<long, std::vector<std::string>>& rows);

// Reads a trials.csv back (header and rows by unit id); errors name the file and line.
void ReadTrialsCsv(const std::filesystem::path& path, std::vector<std::string>* header,
                   std::map<long, std::vector<std::string>>* rows);

struct MetricSummary {
  long n = 0;
  double mean, median, std, ci_lo, ci_hi;  // NaN when undefined
};
MetricSummary Summarize(std::vector<double> values);

}  // namespace hysid
