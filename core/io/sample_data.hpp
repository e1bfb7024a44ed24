// Measured samples read from CSV files for `hysid identify`: one or more runs of one system, each
// cut into chains of consecutive samples.
//
// Inputs: the column of each name in SampleDataOptions::inputs (a model's measured inputs u), by
// header; a missing input cell drops its row as a missing state cell does.
// Columns: SampleDataOptions::columns when given (`t=NAME` the time column, `run=NAME` the run
// column, the other entries the state columns in model order); otherwise time is the first column (the second
// after a leading run column), the measured state is the columns named after the model's states
// (SampleDataOptions::state_names) when all are present (so `hysid simulate` output is used as is), else
// y1..yn when all are present (older `hysid simulate` output; both sets present as different columns
// is an error), else the first n columns other than time, `j`, `run`, `map`, `q` and `true_*` (the noise-free
// state `hysid simulate` writes beside the measured one). A column named `j` (jump
// counter) is ground truth when present; a column named `run` (or the one named by `run=`) splits a file into
// runs, whose rows must be contiguous. Each file is one run otherwise. The `j` of several runs is joined
// into one counter: each run continues from the previous run's last value, so a run boundary is never a
// jump.
// Chains: a run is cut into chains at a step longer than the maximum gap (default kDefaultGapFactor ×
// the median step). A row with a missing state cell (empty, nan, NA) is dropped and counted; the
// chain goes on across it (the step from the sample before it to the one after it is judged by the
// gap rule like any other). Steps may differ from sample to sample; time must increase within a run.
// Checks, each an error naming file, line and column: the CSV's own (non-numeric, infinite, wrong
// cell count, empty, quoting), too few columns for the model, an unknown column name, fewer than 3
// samples or more than the samples limit (kMaxSamples), time missing, not strictly increasing or
// a step below kMinStep, a time or state cell beyond ±kMaxMagnitude, a state column whose largest |value|
// is below kMinMagnitude and not 0, a
// `j` cell that is not an integer in [0, 2^31 − 1] or is below the one before it in its run, a `map`
// or `q` cell that is not an integer in [−1, 10^6], two
// columns of the same name, a run cell that is missing or not an integer, the
// rows of a run not contiguous.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/io/csv.hpp"
#include "core/model/model.hpp"

namespace hysid {

// The largest |value| accepted for time and state cells.
inline constexpr double kMaxMagnitude = 1e150;
// The smallest largest-|value| of a state column that is not all zero (1 / kMaxMagnitude: products of
// states and their squares stay normal numbers).
inline constexpr double kMinMagnitude = 1e-150;
// The smallest time step accepted (1 / kMaxMagnitude: rates Δξ/Δt stay within range).
inline constexpr double kMinStep = 1e-150;
// The default maximum gap, in median steps.
inline constexpr double kDefaultGapFactor = 5.0;

struct SampleDataOptions {
  // Column choice by header name: "t=NAME" (time), "run=NAME" (run column), the rest the states in
  // model order (exactly n of them when any is given). Empty: the default rule above.
  std::vector<std::string> columns{};
  // The model's inputs (ModelSpec::inputs), each read from the column of its name (refused by name
  // when the header has none); a row with a missing input cell is left out as one with a missing
  // state cell. The default state rule skips these columns.
  std::vector<std::string> inputs{};
  // A step longer than this (seconds) starts a new chain. 0: kDefaultGapFactor × the median step.
  double max_gap = 0.0;
  // The model's state names, for the default rule (empty: only y1..yn and the columns' order).
  std::vector<std::string> state_names{};
};

// A data row left out for a missing state cell.
struct MissingRow {
  int run = 0;     // its run (0-based, as SampleData::run)
  long line = 0;   // its line in its file
  double t = 0.0;  // its time
};

// A sample left out as an outlier (LeaveOutOutliers): where it was, the measured state (its row of
// y) that stood off its neighbours, its value, and its second difference in robust sd.
struct OutlierSample {
  int run = 0;
  long line = 0;
  double t = 0.0;
  int row = 0;
  double value = 0.0;
  double sds = 0.0;
};

struct SampleData {
  std::string path;                   // the file, or the files joined with ", "
  std::vector<double> t;              // per sample: its time (the run's own clock)
  double dt = 0.0;                    // uniform data: the mean step (t_K − t_0)/K; else the median step
  double max_gap = 0.0;               // the maximum gap in use
  bool uniform = true;                // one run, one chain, every step within 1e-6 relative of the mean step
  Mat y;                              // n × K measured states (finite; rows with missing cells are dropped)
  Mat u;                              // m × K measured inputs (SampleDataOptions::inputs), finite
  std::optional<std::vector<int>> j;  // ground-truth jump counter, when every file has one
  // A hybrid automaton's ground truth, when every file has the column: `map`, the map (0-based, model
  // order) of the latest jump at or before the sample (−1 before the first), and `q`, the mode.
  std::optional<std::vector<int>> map, q;
  std::vector<std::string> state_columns;  // the header names used for the state
  std::vector<std::string> input_columns;  // the header names used for the inputs
  std::vector<int> run;                    // per sample: its run (0-based)
  std::vector<std::uint8_t> chain_start;   // per sample: 1 where a chain starts (sample 0 included)
  std::vector<long> line;                  // per sample: its line in its file
  std::vector<std::string> run_names;      // per run: "FILE" or "FILE run R"
  long missing_rows = 0;                   // rows dropped for a missing state cell
  std::vector<MissingRow> missing;         // those rows, in file order
  long first_missing_line = 0;             // the first such row's line (0: none)
  long gaps = 0;                           // chain breaks at a step longer than max_gap
  std::vector<OutlierSample> outliers;     // samples left out as outliers (LeaveOutOutliers), in order
  long chains() const;
  // Bytes held by the per-sample arrays (t, y, u, j, run, chain_start, line; by capacity): with n
  // states, m inputs and a j column, (8 + 8n + 8m + 4 + 4 + 1 + 8) per sample once read.
  std::size_t HeldBytes() const;
};

// A sample that stands alone off its neighbours in one measured state is left out (the chain goes
// on across it, as across a row with a missing cell) and listed in `outliers`: its second difference
// d_k = y_{k+1} − 2y_k + y_{k−1} beyond kOutlierSds robust sd (1.4826 × the median absolute deviation
// of that state's d over every chain: one noise level per state, as the fit has it), and each
// neighbour's d_{k±1} of the other sign and 0.25–0.75 of |d_k|: the (1, −2, 1) pattern of one
// displaced sample. A kink bends one or two samples' d the same way, a step in the state gives
// (1, −1), noise never reaches it. Samples 2 to K−3 of chains of at least 12 samples whose steps from
// k−2 to k+2 are within kOutlierStepRatio of each other; beside a missing row d is taken on the
// actual times (twice the line through the neighbours at t_k, less y_k), and each neighbour's share of
// a displaced sample's |d_k| is then its own step away from k over its two steps (0.5 on equal steps),
// which its |d| must meet within ± 0.25. Two neighbours
// displaced the same way by δ1 and δ2 (on equal steps, k−2 to k+3) are left out together when d at
// both is beyond kOutlierSds robust sd and d from k−1 to k+2 is (δ1, δ2 − 2δ1, δ1 − 2δ2, δ2) within a
// quarter of the larger: the pattern of a pair of bad frames, which neither a kink nor a step makes.
inline constexpr double kOutlierSds = 10.0;
inline constexpr double kOutlierStepRatio = 3.0;
void LeaveOutOutliers(SampleData* data);

// Throws std::invalid_argument with "FILE:LINE: column C ('name'): ..." or "FILE: ..." messages.
// The files are read one at a time, each streamed row by row into the samples (ReadCsvRows; memory:
// the samples and one record); SampleDataFromTables makes the same checks row by row on tables
// already read.
SampleData ReadSampleData(const std::vector<std::string>& paths, int state_size,
                          const SampleDataOptions& options = {});
SampleData ReadSampleData(const std::string& path, int state_size);
// The same checks on tables already read (ReadCsvStream); errors name table.path.
SampleData SampleDataFromTables(const std::vector<CsvTable>& tables, int state_size,
                                const SampleDataOptions& options = {});
SampleData SampleDataFromTable(const CsvTable& table, int state_size);
// Runs given as arrays (the Python module): y[r] is run r's n × K samples (a non-finite entry: the
// sample is missing), times[r] its K times, or empty for k·dt. The same checks and chains; an error
// names "run R" (1-based) as the file and the sample number (1-based) as the line.
SampleData SampleDataFromArrays(const std::vector<std::vector<double>>& times, const std::vector<Mat>& y,
                                double dt, const SampleDataOptions& options = {});

}  // namespace hysid
