// Measured inputs u(t) ∈ ℝᵐ given at sample times: what a run of a model with inputs reads.
//
// Between two samples u is interpolated linearly; outside [times.front(), times.back()] it is held at
// the end value (a caller checks the range first: InputRangeError). The run loop stops CVODE at the
// input samples where u has a kink (InputKinkTimes, SimOptions::input_kink) and lets CVODE's error
// control step across the others: between samples the state is C², across them C¹, and a sample
// where the slope barely changes (a smooth signal sampled finely) costs the error test nothing.
// Sources: a CSV file (ReadInputSignal: a column `t` and one column per input name, by header), the
// columns of a data file (core/io/sample_data.hpp: SampleData::u), or the model file's default
// expressions of t evaluated at the sample times (the command line's simulate).
#pragma once

#include <string>
#include <vector>

#include "core/model/model.hpp"

namespace hysid {

struct InputSignal {
  std::vector<double> times;  // K sample times, strictly increasing
  Mat values;                 // m × K: values.col(k) = u(times[k])

  int size() const { return static_cast<int>(values.rows()); }  // m
  bool empty() const { return times.empty(); }
  // u(t) into u[0..m): linear interpolation between the two samples around t (the sample itself at a
  // sample time), the end value outside the range. K = 1: that value everywhere.
  void At(double t, double* u) const;
  // The same, starting the search for t's interval at *hint (an index into times, updated to the
  // interval found): O(1) for a run's times, which move by small steps.
  void At(double t, double* u, long* hint) const;
};

// The interior sample times where the interpolated u has a kink: some input's slope changes by more
// than `threshold` times that input's median slope magnitude |s| over the signal (its largest |s| when
// the median is 0: an input held most of the time). Increasing; the run loop stops CVODE there only.
std::vector<double> InputKinkTimes(const InputSignal& signal, double threshold);

// Reads the inputs `names` from the CSV file `path` (core/io/csv.hpp): the column `t` (time) and the
// column of each name, found by header (other columns are ignored). Throws std::invalid_argument
// "FILE: ..." for a missing column (naming the input and the header), fewer than 2 rows, and
// "FILE:LINE: column C ('name'): ..." for a missing cell, a time not strictly increasing or a cell
// beyond ±1e150.
InputSignal ReadInputSignal(const std::string& path, const std::vector<std::string>& names);

// Checks a signal built elsewhere (sizes agree, times strictly increasing and finite, values finite);
// "" when sound, else why, naming `what` (a file or an option) and the first bad sample (1-based).
std::string InputSignalError(const InputSignal& signal, const std::string& what);

// "" when [t0, t1] lies within the signal's time range, else why: the inputs `names`, the range
// given and the range needed. An input held past its last sample is never silently made up.
std::string InputRangeError(const InputSignal& signal, const std::vector<std::string>& names, double t0,
                            double t1);

}  // namespace hysid
