#include "core/io/sample_data.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/io/csv.hpp"

namespace hysid {

SampleData ReadSampleData(const std::string& path, int state_size) {
  return SampleDataFromTable(ReadCsv(path), state_size);
}

SampleData SampleDataFromTable(const CsvTable& table, int state_size) {
  const std::string& path = table.path;
  SampleData data;
  data.path = path;
  const int cols = static_cast<int>(table.header.size());
  // State columns: y1..yn if present, else the first n non-time, non-j columns.
  std::vector<int> state;
  bool all_y = true;
  for (int i = 1; i <= state_size; ++i) {
    const int c = table.Find(fmt::format("y{}", i));
    if (c < 0) {
      all_y = false;
      break;
    }
    state.push_back(c);
  }
  if (!all_y) {
    state.clear();
    for (int c = 1; c < cols && static_cast<int>(state.size()) < state_size; ++c) {
      if (table.header[static_cast<std::size_t>(c)] != "j") state.push_back(c);
    }
  }
  if (static_cast<int>(state.size()) < state_size) {
    throw std::invalid_argument(
        fmt::format("{}:1: {} columns ({}); need time + {} state columns for the model", path, cols,
                    fmt::join(table.header, ","), state_size));
  }
  for (int c : state) data.state_columns.push_back(table.header[static_cast<std::size_t>(c)]);
  const long k = table.rows();
  if (k < 3) {
    throw std::invalid_argument(fmt::format("{}: {} samples; the identifier needs at least 3", path, k));
  }
  // Magnitudes: beyond kMaxMagnitude, squares and sums in the estimators and set metrics overflow.
  std::vector<int> checked = state;
  checked.push_back(0);
  for (int c : checked) {
    const auto& col = table.columns[static_cast<std::size_t>(c)];
    for (std::size_t r = 0; r < col.size(); ++r) {
      if (std::abs(col[r]) > kMaxMagnitude) {
        throw std::invalid_argument(fmt::format(
            "{}:{}: column {} ('{}'): {} is out of range: |value| must be ≤ {:g} (rescale the data)", path,
            table.line_of_row[r], c + 1, table.header[static_cast<std::size_t>(c)], col[r], kMaxMagnitude));
      }
    }
  }
  data.t = table.columns[0];
  const std::string tname = table.header[0];
  for (long i = 1; i < k; ++i) {
    const auto u = static_cast<std::size_t>(i);
    if (!(data.t[u] > data.t[u - 1])) {
      throw std::invalid_argument(
          fmt::format("{}:{}: column 1 ('{}'): time {} is not after {} (line {}): time must increase", path,
                      table.line_of_row[u], tname, data.t[u], data.t[u - 1], table.line_of_row[u - 1]));
    }
  }
  data.dt = (data.t.back() - data.t.front()) / static_cast<double>(k - 1);
  double worst = 0.0;
  long worst_row = 0;
  for (long i = 1; i < k; ++i) {
    const auto u = static_cast<std::size_t>(i);
    const double dev = std::abs((data.t[u] - data.t[u - 1]) - data.dt) / data.dt;
    if (dev > worst) worst = dev, worst_row = i;
  }
  if (worst > 1e-6) {
    const auto u = static_cast<std::size_t>(worst_row);
    throw std::invalid_argument(
        fmt::format("{}:{}: column 1 ('{}'): irregular sampling: step {} differs from the mean step {} by "
                    "{:.3g}% (hysid needs a uniform δt; the tolerance is 1e-4%)",
                    path, table.line_of_row[u], tname, data.t[u] - data.t[u - 1], data.dt, 100.0 * worst));
  }
  data.y.resize(state_size, k);
  for (int i = 0; i < state_size; ++i) {
    const auto& col = table.columns[static_cast<std::size_t>(state[static_cast<std::size_t>(i)])];
    for (long r = 0; r < k; ++r) data.y(i, r) = col[static_cast<std::size_t>(r)];
  }
  if (const int jc = table.Find("j"); jc >= 0) {
    std::vector<int> j(static_cast<std::size_t>(k));
    for (long r = 0; r < k; ++r) {
      const double v = table.columns[static_cast<std::size_t>(jc)][static_cast<std::size_t>(r)];
      if (v != std::floor(v) || v < 0 || v > static_cast<double>(std::numeric_limits<int>::max())) {
        throw std::invalid_argument(
            fmt::format("{}:{}: column {} ('j'): {} is not a jump count (an integer in [0, 2147483647])",
                        path, table.line_of_row[static_cast<std::size_t>(r)], jc + 1, v));
      }
      j[static_cast<std::size_t>(r)] = static_cast<int>(v);
    }
    data.j = std::move(j);
  }
  return data;
}

}  // namespace hysid
