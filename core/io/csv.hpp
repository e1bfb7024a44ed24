// CSV tables (RFC 4180): a header line, then rows of numbers.
//
// Writing: every number with %.17g (round-trips doubles exactly); the file is written under a
// temporary name and renamed on Commit(), so a reader never sees half a file.
// Reading: one record splitter (SplitCsvRecord) for every CSV hysid reads. Fields are separated by
// commas, records by LF, CRLF or a lone CR (a UTF-8 byte order mark first is skipped); a field may be
// quoted, and inside quotes a comma, a line break and a doubled quote ("" = ") are text; a quote
// inside an unquoted field is text. Unquoted fields are
// trimmed of spaces and tabs. Errors name the file, the line and the column. Records and cells are
// bounded (limits.hpp: HYSID_MAX_CSV_LINE, HYSID_MAX_CSV_CELL) before they are held whole, and so is
// the number of rows (HYSID_MAX_CSV_ROWS); a header is required (a first line of numbers is refused).
#pragma once

#include <cstdio>
#include <filesystem>
#include <istream>
#include <span>
#include <string>
#include <string_view>
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
  // Flushes, closes and renames the temporary file onto the target. Throws on I/O failure
  // (the message carries strerror); the temporary file is removed on every failure.
  void Commit() {
    Close();
    Publish();
  }
  // The two halves of Commit, for a set of files committed together: Close() flushes and closes
  // the temporary file, Publish() renames it onto the target. Until Publish() the destructor
  // removes the temporary file.
  void Close();
  void Publish();
  const std::filesystem::path& path() const { return path_; }

 private:
  void FlushIfLarge();
  std::filesystem::path path_;
  std::filesystem::path tmp_path_;
  void Fail(const char* what, int error_number);
  std::FILE* file_ = nullptr;
  bool published_ = false;
  fmt::memory_buffer buffer_;
  std::size_t columns_ = 0;
};

struct CsvTable {
  std::string path;
  std::vector<std::string> header;
  std::vector<std::vector<double>> columns;  // columns[c][r]
  std::vector<long> line_of_row;             // 1-based file line of each data row (its first line)
  long missing_cells = 0;                    // cells read as missing (NaN in columns)
  long rows() const { return columns.empty() ? 0 : static_cast<long>(columns[0].size()); }
  // Index of a header name, or -1.
  int Find(const std::string& name) const;
};

// Reads a numeric CSV with a header line. Lines starting with '#' and blank lines are skipped
// (outside a record). A missing cell (empty, nan, NaN, NA; quoted or not) is stored as NaN and counted.
// Throws std::invalid_argument "FILE:LINE: column C ('name'): ..." for a non-numeric or infinite
// cell, a wrong number of cells, a quote not closed or text after a closing quote, and "FILE: ..."
// for a missing or empty file, or one that is not a regular file (CheckRegularFile: a FIFO would block).
CsvTable ReadCsv(const std::filesystem::path& path);
CsvTable ReadCsvStream(std::istream& in, const std::string& name);

// Splits one record (its line breaks inside quoted fields included, CR of CRLF removed) into cells
// per RFC 4180. False when the record ends inside a quoted field (the caller appends the next line).
// Throws std::invalid_argument "NAME:LINE_NO: column C: ..." for text after a closing quote or a
// cell longer than HYSID_MAX_CSV_CELL.
bool SplitCsvRecord(std::string_view record, const std::string& name, long line_no,
                    std::vector<std::string>* cells);
// The same for a record known to be complete (one line of a file hysid wrote): an open quote is an
// error "NAME:LINE_NO: column C: the quoted cell is not closed".
std::vector<std::string> SplitCsvLine(std::string_view line, const std::string& name, long line_no);

// Reads one line (without its '\n') into `line`, refusing with "NAME:LINE_NO: ..." a line longer
// than the limit HYSID_MAX_CSV_LINE before it is held whole. False at end of input.
bool ReadBoundedLine(std::istream& in, std::string& line, const std::string& name, long line_no);

}  // namespace hysid
