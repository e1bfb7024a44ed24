// libFuzzer harness: the numeric CSV reader. Any input must give a table or std::invalid_argument.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>

#include "core/io/csv.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    const hysid::CsvTable t = hysid::ReadCsvStream(in, "fuzz.csv");
    for (const auto& column : t.columns) {
      if (static_cast<long>(column.size()) != t.rows()) __builtin_trap();  // a ragged table
    }
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
