// libFuzzer harness: the sample-data reader of `hysid identify` (CSV, then the data checks), for a
// model of 2 states. Any input must give data or std::invalid_argument; accepted data are checked.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>

#include "core/io/sample_data.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    const hysid::SampleData d = hysid::SampleDataFromTable(hysid::ReadCsvStream(in, "fuzz.csv"), 2);
    if (d.y.rows() != 2 || d.y.cols() != static_cast<long>(d.t.size()) || d.t.size() < 3) __builtin_trap();
    if (!(d.dt > 0) || !d.y.allFinite()) __builtin_trap();
    if (d.j && d.j->size() != d.t.size()) __builtin_trap();
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
