// Measured samples read from a CSV for `hysid identify`.
//
// Layout: a header line; the first column is time; the measured state is the columns y1..yn when
// all are present (so `hysid simulate` output is used as is), otherwise the first n columns after
// time other than `j`. A column named `j` (jump counter) is ground truth when present.
// Checks, each an error naming file, line and column: the CSV's own (non-numeric, non-finite,
// wrong cell count, empty), too few columns for the model, fewer than 3 samples, time not strictly
// increasing, irregular sampling (a step off the mean step by more than 1e-6 relative), a time or
// state cell beyond ±kMaxMagnitude, and a `j` cell that is not an integer in [0, 2^31 − 1].
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/io/csv.hpp"
#include "core/model/model.hpp"

namespace hysid {

// The largest |value| accepted for time and state cells.
inline constexpr double kMaxMagnitude = 1e150;

struct SampleData {
  std::string path;
  std::vector<double> t;
  double dt = 0.0;                         // the mean step (t_K − t_0)/K
  Mat y;                                   // n × K measured states
  std::optional<std::vector<int>> j;       // ground-truth jump counter, when the file has one
  std::vector<std::string> state_columns;  // the header names used for the state
};

// Throws std::invalid_argument with "FILE:LINE: column C ('name'): ..." or "FILE: ..." messages.
SampleData ReadSampleData(const std::string& path, int state_size);
// The same checks on a table already read (ReadCsvStream); errors name table.path.
SampleData SampleDataFromTable(const CsvTable& table, int state_size);

}  // namespace hysid
