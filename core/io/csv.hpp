// Plain CSV tables: a header line, then rows of numbers.
//
// Writing: every number with %.17g (round-trips doubles exactly); the file is written under a
// temporary name and renamed on Commit(), so a reader never sees half a file.
// Reading: errors name the file, the line and the column.
#pragma once

#include <cstdio>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include <fmt/format.h>

namespace hysid {

class CsvWriter {
 public:
  // Creates the parent directory. Throws std::runtime_error when the file cannot be opened.
  CsvWriter(const std::filesystem::path& path, const std::vector<std::string>& header);
  ~CsvWriter();
  CsvWriter(const CsvWriter&) = delete;
  CsvWriter& operator=(const CsvWriter&) = delete;

  void Row(std::span<const double> values);
  // A row whose cells are already text (for string columns).
  void TextRow(std::span<const std::string> cells);
  // Flushes, closes and renames the temporary file onto the target. Throws on I/O failure.
  void Commit();

 private:
  void FlushIfLarge();
  std::filesystem::path path_;
  std::filesystem::path tmp_path_;
  std::FILE* file_ = nullptr;
  fmt::memory_buffer buffer_;
  std::size_t columns_ = 0;
};

struct CsvTable {
  std::string path;
  std::vector<std::string> header;
  std::vector<std::vector<double>> columns;  // columns[c][r]
  std::vector<long> line_of_row;             // 1-based file line of each data row
  long rows() const { return columns.empty() ? 0 : static_cast<long>(columns[0].size()); }
  // Index of a header name, or -1.
  int Find(const std::string& name) const;
};

// Reads a numeric CSV with a header line. Lines starting with '#' and blank lines are skipped.
// Throws std::invalid_argument "FILE:LINE: column C ('name'): ..." for a non-numeric or
// non-finite cell or a wrong number of cells, and "FILE: ..." for a missing or empty file.
CsvTable ReadCsv(const std::filesystem::path& path);

}  // namespace hysid
