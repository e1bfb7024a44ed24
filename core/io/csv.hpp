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
// the number of rows (HYSID_MAX_CSV_ROWS; each limit read from the environment once per call, not
// per line); a header is required (a first line of numbers is refused).
#pragma once

#include <cstdio>
#include <filesystem>
#include <functional>
#include <istream>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "core/io/files.hpp"

namespace hysid {

class CsvWriter {
 public:
  // Creates the parent directory. Throws std::runtime_error when the file cannot be created. Header
  // names are written as CsvCell gives them.
  CsvWriter(const std::filesystem::path& path, const std::vector<std::string>& header);
  CsvWriter(const CsvWriter&) = delete;
  CsvWriter& operator=(const CsvWriter&) = delete;

  void Row(std::span<const double> values);
  // A row whose cells are text (for string columns), each written as CsvCell gives it.
  void TextRow(std::span<const std::string> cells);
  // Writes, closes and renames the temporary file onto the target (AtomicFile, core/io/files.hpp).
  // Throws on I/O failure (the message carries the path and strerror); the temporary file is removed
  // on every failure.
  void Commit() {
    Close();
    Publish();
  }
  // The two halves of Commit, for a set of files committed together: Close() writes and closes
  // the temporary file, Publish() renames it onto the target. Until Publish() the destructor
  // removes the temporary file.
  void Close();
  void Publish();
  const std::filesystem::path& path() const { return file_.path(); }

 private:
  void FlushIfLarge();
  AtomicFile file_;
  fmt::memory_buffer buffer_;
  std::size_t columns_ = 0;
};

// A cell as RFC 4180 writes it: quoted (with " doubled) when it holds a comma, a quote, a line break
// or a leading or trailing space or tab (which the reader would trim); else as it is.
std::string CsvCell(std::string_view text);
// Cells joined with commas, each through CsvCell (one record, without a line break at the end).
std::string JoinCsvRecord(std::span<const std::string> cells);

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

// A CSV read row by row, with the checks and messages of ReadCsvStream, without the table held:
// `header` is called once with the table's path and header (no rows), then `row` with each data row's
// cells in header order (NaN for a missing cell) and its first line. Memory: one record.
struct CsvRowSink {
  std::function<void(const CsvTable& head)> header;
  std::function<void(std::span<const double> cells, long line)> row;
};
void ReadCsvRows(const std::filesystem::path& path, const CsvRowSink& sink);
void ReadCsvRowsStream(std::istream& in, const std::string& name, const CsvRowSink& sink);

// Splits one record (its line breaks inside quoted fields included, CR of CRLF removed) into cells
// per RFC 4180. False when the record ends inside a quoted field (the caller appends the next line).
// Throws std::invalid_argument "NAME:LINE_NO: column C: ..." for text after a closing quote or a
// cell longer than HYSID_MAX_CSV_CELL.
bool SplitCsvRecord(std::string_view record, const std::string& name, long line_no,
                    std::vector<std::string>* cells);
// The same for a record known to be complete (one line of a file hysid wrote): an open quote is an
// error "NAME:LINE_NO: column C: the quoted cell is not closed".
std::vector<std::string> SplitCsvLine(std::string_view line, const std::string& name, long line_no);

// Reads the record that starts at the next line of `in` (further lines appended while a quoted cell is
// open) into *cells; *line_no is the line before it on entry and its last line on return. False at
// end of input. Throws as SplitCsvRecord, and "NAME:LINE: ... not closed before the end of the file".
bool ReadCsvRecord(std::istream& in, const std::string& name, long* line_no, std::vector<std::string>* cells);

// Reads one line (without its LF, CR LF or lone CR) into `line`, refusing with "NAME:LINE_NO: ..." a
// line longer than the limit HYSID_MAX_CSV_LINE before it is held whole; *lone_cr (when given) says
// whether it ended in a CR alone. False at end of input.
bool ReadBoundedLine(std::istream& in, std::string& line, const std::string& name, long line_no,
                     bool* lone_cr = nullptr);

}  // namespace hysid
