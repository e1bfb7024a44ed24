#include "sim/input_signal.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/io/csv.hpp"
#include "core/io/sample_data.hpp"

namespace hysid {

void InputSignal::At(double t, double* u) const {
  const Eigen::Index m = values.rows();
  const auto count = static_cast<Eigen::Index>(times.size());
  if (count == 0) return;
  if (count == 1 || !(t > times.front())) {  // before the range (or NaN): the first value
    for (Eigen::Index i = 0; i < m; ++i) u[i] = values(i, 0);
    return;
  }
  if (t >= times.back()) {
    for (Eigen::Index i = 0; i < m; ++i) u[i] = values(i, count - 1);
    return;
  }
  // times[hi − 1] ≤ t < times[hi], 1 ≤ hi ≤ count − 1.
  const auto hi = static_cast<Eigen::Index>(std::upper_bound(times.begin(), times.end(), t) - times.begin());
  const double t0 = times[static_cast<std::size_t>(hi - 1)], t1 = times[static_cast<std::size_t>(hi)];
  const double w = (t - t0) / (t1 - t0);
  for (Eigen::Index i = 0; i < m; ++i) u[i] = values(i, hi - 1) + w * (values(i, hi) - values(i, hi - 1));
}

InputSignal ReadInputSignal(const std::string& path, const std::vector<std::string>& names) {
  const CsvTable table = ReadCsv(path);
  const int time = table.Find("t");
  if (time < 0) {
    throw std::invalid_argument(fmt::format("{}: no column 't' (the input times); the header is {}", path,
                                            fmt::join(table.header, ",")));
  }
  std::vector<int> columns;
  for (const std::string& name : names) {
    columns.push_back(table.Find(name));
    if (columns.back() < 0) {
      throw std::invalid_argument(
          fmt::format("{}: no column '{}' for the model's input '{}'; the header is {}", path, name, name,
                      fmt::join(table.header, ",")));
    }
  }
  if (table.rows() < 2) {
    throw std::invalid_argument(
        fmt::format("{}: {} rows; an input signal needs at least 2", path, table.rows()));
  }
  InputSignal s;
  s.times = table.columns[static_cast<std::size_t>(time)];
  s.values.resize(static_cast<Eigen::Index>(names.size()), table.rows());
  for (std::size_t i = 0; i < names.size(); ++i) {
    const std::vector<double>& col = table.columns[static_cast<std::size_t>(columns[i])];
    s.values.row(static_cast<Eigen::Index>(i)) = Eigen::Map<const Vec>(col.data(), table.rows()).transpose();
  }
  // The checks of InputSignalError, with the file's line and column in the message.
  columns.insert(columns.begin(), time);
  for (long r = 0; r < table.rows(); ++r) {
    const long line = table.line_of_row[static_cast<std::size_t>(r)];
    for (int c : columns) {
      const double v = table.columns[static_cast<std::size_t>(c)][static_cast<std::size_t>(r)];
      const std::string where = fmt::format("{}:{}: column {} ('{}')", path, line, c + 1,
                                            table.header[static_cast<std::size_t>(c)]);
      if (std::isnan(v))
        throw std::invalid_argument(where + ": the value is missing; an input is needed at every row");
      if (std::abs(v) > kMaxMagnitude) {
        throw std::invalid_argument(
            fmt::format("{}: {} is out of range: |value| must be ≤ {:g}", where, v, kMaxMagnitude));
      }
    }
    if (r > 0 && !(s.times[static_cast<std::size_t>(r)] > s.times[static_cast<std::size_t>(r - 1)])) {
      throw std::invalid_argument(fmt::format(
          "{}:{}: column {} ('t'): {} after {}: times must increase strictly", path, line, time + 1,
          s.times[static_cast<std::size_t>(r)], s.times[static_cast<std::size_t>(r - 1)]));
    }
  }
  return s;
}

std::string InputSignalError(const InputSignal& signal, const std::string& what) {
  const auto count = static_cast<Eigen::Index>(signal.times.size());
  if (signal.values.cols() != count) {
    return fmt::format("{}: {} times but {} input samples", what, count, signal.values.cols());
  }
  if (count == 0) return fmt::format("{}: no input samples", what);
  for (Eigen::Index k = 0; k < count; ++k) {
    const double t = signal.times[static_cast<std::size_t>(k)];
    if (!std::isfinite(t)) return fmt::format("{}: sample {}: the time {} is not finite", what, k + 1, t);
    if (k > 0 && !(t > signal.times[static_cast<std::size_t>(k - 1)])) {
      return fmt::format("{}: sample {}: the time {} does not increase (after {})", what, k + 1, t,
                         signal.times[static_cast<std::size_t>(k - 1)]);
    }
    if (!signal.values.col(k).allFinite()) {
      return fmt::format("{}: sample {} (t = {}): an input value is not finite", what, k + 1, t);
    }
  }
  return "";
}

std::string InputRangeError(const InputSignal& signal, const std::vector<std::string>& names, double t0,
                            double t1) {
  if (signal.times.empty()) return fmt::format("the inputs {} have no samples", fmt::join(names, ", "));
  const double lo = signal.times.front(), hi = signal.times.back();
  if (t0 >= lo && t1 <= hi) return "";
  return fmt::format(
      "the inputs {} are given on [{}, {}]; the run needs [{}, {}] (an input is never held past its samples)",
      fmt::join(names, ", "), lo, hi, t0, t1);
}

}  // namespace hysid
