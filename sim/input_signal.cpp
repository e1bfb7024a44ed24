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
  long hint = 0;
  At(t, u, &hint);
}

void InputSignal::At(double t, double* u, long* hint) const {
  const Eigen::Index m = values.rows();
  const auto count = static_cast<long>(times.size());
  if (count == 0) return;
  if (count == 1 || !(t > times.front())) {  // before the range (or NaN): the first value
    for (Eigen::Index i = 0; i < m; ++i) u[i] = values(i, 0);
    return;
  }
  if (t >= times.back()) {
    for (Eigen::Index i = 0; i < m; ++i) u[i] = values(i, count - 1);
    return;
  }
  // times[hi − 1] ≤ t < times[hi], 1 ≤ hi ≤ count − 1: the hint's interval or a neighbour's when t is
  // there (the same hi as the search), else a binary search.
  long hi = std::clamp(*hint, 1L, count - 1);
  const auto at = [&](long k) { return times[static_cast<std::size_t>(k)]; };
  if (!(at(hi - 1) <= t && t < at(hi))) {
    if (hi + 1 < count && at(hi) <= t && t < at(hi + 1)) {
      ++hi;
    } else if (hi > 1 && at(hi - 2) <= t && t < at(hi - 1)) {
      --hi;
    } else {
      hi = static_cast<long>(std::upper_bound(times.begin(), times.end(), t) - times.begin());
    }
  }
  *hint = hi;
  const double t0 = at(hi - 1), t1 = at(hi);
  const double w = (t - t0) / (t1 - t0);
  for (Eigen::Index i = 0; i < m; ++i) u[i] = values(i, hi - 1) + w * (values(i, hi) - values(i, hi - 1));
}

std::vector<double> InputKinkTimes(const InputSignal& signal, double threshold) {
  const auto count = static_cast<Eigen::Index>(signal.times.size());
  std::vector<double> kinks;
  if (count < 3) return kinks;
  const auto dt = [&](Eigen::Index k) {
    return signal.times[static_cast<std::size_t>(k + 1)] - signal.times[static_cast<std::size_t>(k)];
  };
  std::vector<char> kink(static_cast<std::size_t>(count), 0);
  std::vector<double> slope(static_cast<std::size_t>(count - 1)), magnitude;
  for (Eigen::Index i = 0; i < signal.values.rows(); ++i) {
    for (Eigen::Index k = 0; k + 1 < count; ++k) {
      slope[static_cast<std::size_t>(k)] = (signal.values(i, k + 1) - signal.values(i, k)) / dt(k);
    }
    magnitude.resize(slope.size());
    std::transform(slope.begin(), slope.end(), magnitude.begin(), [](double s) { return std::abs(s); });
    const auto middle = magnitude.begin() + static_cast<std::ptrdiff_t>(magnitude.size() / 2);
    std::nth_element(magnitude.begin(), middle, magnitude.end());
    const double scale = *middle > 0.0 ? *middle : *std::max_element(magnitude.begin(), magnitude.end());
    const double limit = threshold * scale;
    for (Eigen::Index k = 1; k + 1 < count; ++k) {
      const double change = std::abs(slope[static_cast<std::size_t>(k)] - slope[static_cast<std::size_t>(k - 1)]);
      if (change > limit) kink[static_cast<std::size_t>(k)] = 1;
    }
  }
  for (Eigen::Index k = 1; k + 1 < count; ++k) {
    if (kink[static_cast<std::size_t>(k)]) kinks.push_back(signal.times[static_cast<std::size_t>(k)]);
  }
  return kinks;
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
