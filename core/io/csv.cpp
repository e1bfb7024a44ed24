#include "core/io/csv.hpp"

#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <system_error>

#include "core/io/files.hpp"
#include "core/io/limits.hpp"

namespace hysid {

namespace {

const std::filesystem::path& WithParentDirectory(const std::filesystem::path& path) {
  if (path.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(path.parent_path(), ec);
    if (ec) {
      throw std::runtime_error(
          fmt::format("{}: cannot create the directory: {}", path.parent_path().string(), ec.message()));
    }
  }
  return path;
}

void AppendCell(fmt::memory_buffer* buffer, std::string_view text) {
  const std::string cell = CsvCell(text);
  buffer->append(cell.data(), cell.data() + cell.size());
}

}  // namespace

std::string CsvCell(std::string_view text) {
  const bool quote = text.find_first_of(",\"\r\n") != std::string_view::npos ||
                     (!text.empty() && (text.front() == ' ' || text.front() == '\t' || text.back() == ' ' ||
                                        text.back() == '\t'));
  if (!quote) return std::string(text);
  std::string out = "\"";
  for (char c : text) {
    if (c == '"') out.push_back('"');
    out.push_back(c);
  }
  out.push_back('"');
  return out;
}

std::string JoinCsvRecord(std::span<const std::string> cells) {
  std::string s;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (i) s.push_back(',');
    s += CsvCell(cells[i]);
  }
  return s;
}

CsvWriter::CsvWriter(const std::filesystem::path& path, const std::vector<std::string>& header)
    : file_(WithParentDirectory(path)), columns_(header.size()) {
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (i) buffer_.push_back(',');
    AppendCell(&buffer_, header[i]);
  }
  buffer_.push_back('\n');
}

void CsvWriter::Row(std::span<const double> values) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (i) buffer_.push_back(',');
    fmt::format_to(std::back_inserter(buffer_), "{:.17g}", values[i]);
  }
  buffer_.push_back('\n');
  FlushIfLarge();
}

void CsvWriter::TextRow(std::span<const std::string> cells) {
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (i) buffer_.push_back(',');
    AppendCell(&buffer_, cells[i]);
  }
  buffer_.push_back('\n');
  FlushIfLarge();
}

void CsvWriter::FlushIfLarge() {
  if (buffer_.size() < (1u << 16)) return;
  file_.Write(std::string_view(buffer_.data(), buffer_.size()));
  buffer_.clear();
}

void CsvWriter::Close() {
  file_.Write(std::string_view(buffer_.data(), buffer_.size()));
  buffer_.clear();
  file_.Close();
}

void CsvWriter::Publish() { file_.Publish(); }

int CsvTable::Find(const std::string& name) const {
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i] == name) return static_cast<int>(i);
  }
  return -1;
}

namespace {

// The limits of one read, each read from the environment once (limits.hpp), not per line or cell.
struct CsvLimits {
  std::size_t line = static_cast<std::size_t>(LimitValue(kMaxCsvLine));
  std::size_t cell = static_cast<std::size_t>(LimitValue(kMaxCsvCell));
};

// ReadBoundedLine with the line limit given.
bool ReadLine(std::istream& in, std::string& line, const std::string& name, long line_no, bool* lone_cr,
              std::size_t max) {
  line.clear();
  if (lone_cr != nullptr) *lone_cr = false;
  std::streambuf* buf = in.rdbuf();
  bool any = false;
  while (true) {
    const int c = buf->sbumpc();
    if (c == std::char_traits<char>::eof()) {
      in.setstate(std::ios::eofbit);
      return any;
    }
    any = true;
    if (c == '\n') return true;
    if (c == '\r') {  // CR LF, or a CR alone (classic Mac OS): one record separator
      if (buf->sgetc() == '\n') {
        buf->sbumpc();
      } else if (lone_cr != nullptr) {
        *lone_cr = true;
      }
      return true;
    }
    if (line.size() >= max) {
      throw std::invalid_argument(
          fmt::format("{}:{}: the line is longer than the limit of {} {} (raise it with {}=N)", name, line_no,
                      max, kMaxCsvLine.what, kMaxCsvLine.variable));
    }
    line.push_back(static_cast<char>(c));
  }
}

}  // namespace

bool ReadBoundedLine(std::istream& in, std::string& line, const std::string& name, long line_no,
                     bool* lone_cr) {
  return ReadLine(in, line, name, line_no, lone_cr, CsvLimits{}.line);
}

namespace {

std::string_view Trim(std::string_view s) {
  std::size_t b = 0, e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r')) --e;
  return s.substr(b, e - b);
}

void CheckCellSize(std::string_view cell, const std::string& name, long line_no, std::size_t column,
                   std::size_t max) {
  if (cell.size() > max) {
    throw std::invalid_argument(fmt::format(
        "{}:{}: column {}: the cell '{}' is longer than the limit of {} {} (raise it with {}=N)", name,
        line_no, column, Abbreviated(cell, 40), max, kMaxCsvCell.what, kMaxCsvCell.variable));
  }
}

// A quoted field starting at rec[open] (the quote): its text into *cell, the index after the closing
// quote into *end. False when the record ends inside the quotes.
bool QuotedField(std::string_view rec, std::size_t open, std::string* cell, std::size_t* end) {
  std::size_t j = open + 1;
  while (j < rec.size()) {
    const std::size_t quote = rec.find('"', j);
    if (quote == std::string_view::npos) return false;
    cell->append(rec.substr(j, quote - j));
    if (quote + 1 < rec.size() && rec[quote + 1] == '"') {  // "" inside quotes
      cell->push_back('"');
      j = quote + 2;
      continue;
    }
    *end = quote + 1;
    return true;
  }
  return false;
}

}  // namespace

namespace {

// SplitCsvRecord with the cell limit given. The strings already in *cells are reused (assigned, not
// allocated anew per cell); on return *cells holds exactly the record's cells (false: those complete).
bool SplitRecord(std::string_view rec, const std::string& name, long line_no, std::size_t max_cell,
                 std::vector<std::string>* cells) {
  std::size_t used = 0;
  auto next = [&]() -> std::string& {
    if (used == cells->size()) cells->emplace_back();
    std::string& cell = (*cells)[used++];
    cell.clear();
    return cell;
  };
  std::size_t i = 0;
  const std::size_t n = rec.size();
  while (true) {
    std::size_t b = i;
    while (b < n && (rec[b] == ' ' || rec[b] == '\t')) ++b;
    std::string& cell = next();
    if (b < n && rec[b] == '"') {
      std::size_t j = 0;
      if (!QuotedField(rec, b, &cell, &j)) {
        cells->resize(used - 1);
        return false;
      }
      while (j < n && (rec[j] == ' ' || rec[j] == '\t' || rec[j] == '\r')) ++j;
      if (j < n && rec[j] != ',') {
        throw std::invalid_argument(fmt::format(
            "{}:{}: column {}: text '{}' after the closing quote of a quoted cell (write a quote "
            "inside quotes as \"\")",
            name, line_no, used, Abbreviated(rec.substr(j, rec.find(',', j) - j), 40)));
      }
      CheckCellSize(cell, name, line_no, used, max_cell);
      i = j;
    } else {
      const std::size_t comma = rec.find(',', i);
      const std::string_view raw = Trim(rec.substr(i, comma == std::string_view::npos ? comma : comma - i));
      CheckCellSize(raw, name, line_no, used, max_cell);
      cell.assign(raw);
      i = comma == std::string_view::npos ? n : comma;
    }
    if (i >= n) {
      cells->resize(used);
      return true;
    }
    ++i;  // past the comma
  }
}

}  // namespace

bool SplitCsvRecord(std::string_view rec, const std::string& name, long line_no,
                    std::vector<std::string>* cells) {
  return SplitRecord(rec, name, line_no, CsvLimits{}.cell, cells);
}

std::vector<std::string> SplitCsvLine(std::string_view line, const std::string& name, long line_no) {
  std::vector<std::string> cells;
  if (!SplitCsvRecord(line, name, line_no, &cells)) {
    throw std::invalid_argument(
        fmt::format("{}:{}: column {}: the quoted cell is not closed", name, line_no, cells.size() + 1));
  }
  return cells;
}

namespace {

bool ParseNumber(std::string_view cell, double* value) {
  cell = Trim(cell);
  const char* first = cell.data();
  const char* last = cell.data() + cell.size();
  if (!cell.empty() && *first == '+') ++first;
  const auto [end, ec] = std::from_chars(first, last, *value);
  return !cell.empty() && ec == std::errc() && end == last;
}

// Empty, NA, or a number that reads as NaN (nan, NaN, -nan).
bool IsMissing(std::string_view cell, double* value) {
  cell = Trim(cell);
  if (cell.empty() || cell == "NA") return true;
  return ParseNumber(cell, value) && std::isnan(*value);
}

void CheckHeader(const CsvTable& table, long line_no) {
  bool all_numbers = true;
  for (std::size_t c = 0; c < table.header.size(); ++c) {
    const std::string& h = table.header[c];
    if (h.empty()) {
      throw std::invalid_argument(
          fmt::format("{}:{}: column {} of the header is empty", table.path, line_no, c + 1));
    }
    double v = 0;
    all_numbers = all_numbers && ParseNumber(h, &v);
  }
  if (all_numbers) {
    throw std::invalid_argument(
        fmt::format("{}:{}: the first line is numbers, not a header; add a header line such as t,y1,y2",
                    table.path, line_no));
  }
}

// The record that starts with `line` (line *line_no, ended by a lone CR when `lone_cr`): further
// lines are appended while a quoted field is open, each joined by the break that ended the line
// before it (LF for LF and CR LF, CR for a lone CR). Its cells into *cells; *line_no ends at the
// record's last line. `line` is the caller's buffer (split in place when the record is one line).
void ReadRecord(std::istream& in, const std::string& name, std::string& line, bool lone_cr, long* line_no,
                std::vector<std::string>* cells, const CsvLimits& limits) {
  const long first = *line_no;
  if (SplitRecord(line, name, first, limits.cell, cells)) return;
  std::string record = line;
  do {
    const bool break_is_cr = lone_cr;
    if (!ReadLine(in, line, name, *line_no + 1, &lone_cr, limits.line)) {
      throw std::invalid_argument(
          fmt::format("{}:{}: column {}: the quoted cell is not closed before the end "
                      "of the file",
                      name, first, cells->size() + 1));
    }
    ++*line_no;
    if (record.size() + line.size() + 1 > limits.line) {
      throw std::invalid_argument(fmt::format(
          "{}:{}: the record (a quoted cell over several lines) is longer than the limit of {} {} (raise it "
          "with {}=N)",
          name, first, limits.line, kMaxCsvLine.what, kMaxCsvLine.variable));
    }
    record.push_back(break_is_cr ? '\r' : '\n');
    record += line;
  } while (!SplitRecord(record, name, first, limits.cell, cells));
}

// One data row's cells as numbers into *values (missing cells as NaN).
void ParseRow(const CsvTable& head, const std::vector<std::string>& cells, long line_no,
              std::vector<double>* values) {
  if (cells.size() != head.header.size()) {
    throw std::invalid_argument(fmt::format("{}:{}: {} cells, the header has {} columns", head.path, line_no,
                                            cells.size(), head.header.size()));
  }
  values->resize(cells.size());
  for (std::size_t c = 0; c < cells.size(); ++c) {
    double& value = (*values)[c];
    if (IsMissing(cells[c], &value)) {
      value = std::numeric_limits<double>::quiet_NaN();
      continue;
    }
    if (!ParseNumber(cells[c], &value)) {
      throw std::invalid_argument(fmt::format("{}:{}: column {} ('{}'): '{}' is not a number", head.path,
                                              line_no, c + 1, head.header[c], Abbreviated(cells[c])));
    }
    if (!std::isfinite(value)) {
      throw std::invalid_argument(fmt::format("{}:{}: column {} ('{}'): '{}' is not finite", head.path,
                                              line_no, c + 1, head.header[c], Abbreviated(cells[c])));
    }
  }
}

std::ifstream OpenCsv(const std::filesystem::path& path) {
  CheckRegularFile(path.string(), "data file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument(IoError(path, "cannot open file", errno));
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw std::invalid_argument(fmt::format("{}: is a directory, expected a CSV file", path.string()));
  }
  return in;
}

}  // namespace

void ReadCsvRows(const std::filesystem::path& path, const CsvRowSink& sink) {
  std::ifstream in = OpenCsv(path);
  ReadCsvRowsStream(in, path.string(), sink);
}

namespace {

// A UTF-16 file (a byte order mark FF FE or FE FF, or NUL bytes between the characters of the
// first line, as spreadsheet programs save "Unicode text"): named, not read as garbled cells.
void CheckNotUtf16(std::string_view first_line, const std::string& name) {
  const bool bom = first_line.starts_with("\xFF\xFE") || first_line.starts_with("\xFE\xFF");
  if (!bom && first_line.find('\0') == std::string_view::npos) return;
  throw std::invalid_argument(
      fmt::format("{}: is UTF-16 ({}); save it as UTF-8 (CSV, comma-separated)", name,
                  bom ? "its first bytes are a UTF-16 byte order mark" : "it holds NUL bytes"));
}

}  // namespace

void ReadCsvRowsStream(std::istream& in, const std::string& name, const CsvRowSink& sink) {
  CsvTable head;
  head.path = name;
  std::string line;
  std::vector<std::string> cells;
  std::vector<double> values;
  long line_no = 0, rows = 0;
  bool have_header = false;
  const std::int64_t max_rows = LimitValue(kMaxCsvRows);
  const CsvLimits limits;
  bool lone_cr = false;
  while (ReadLine(in, line, name, line_no + 1, &lone_cr, limits.line)) {
    ++line_no;
    if (line_no == 1 && line.starts_with(kUtf8Bom)) line.erase(0, kUtf8Bom.size());
    if (line_no == 1) CheckNotUtf16(line, name);
    const std::string_view trimmed = Trim(line);
    if (trimmed.empty() || trimmed[0] == '#') continue;
    const long first = line_no;
    ReadRecord(in, name, line, lone_cr, &line_no, &cells, limits);
    if (!have_header) {
      head.header = std::move(cells);
      cells = {};
      CheckHeader(head, first);
      have_header = true;
      sink.header(head);
      continue;
    }
    if (rows >= max_rows) CheckLimit(kMaxCsvRows, max_rows + 1, fmt::format("{}:{}", name, first));
    ParseRow(head, cells, first, &values);
    ++rows;
    sink.row(values, first);
  }
  if (!have_header) throw std::invalid_argument(fmt::format("{}: file is empty", name));
}

CsvTable ReadCsv(const std::filesystem::path& path) {
  std::ifstream in = OpenCsv(path);
  return ReadCsvStream(in, path.string());
}

CsvTable ReadCsvStream(std::istream& in, const std::string& name) {
  CsvTable table;
  CsvRowSink sink;
  sink.header = [&](const CsvTable& head) {
    table = head;
    table.columns.assign(table.header.size(), {});
  };
  sink.row = [&](std::span<const double> cells, long line) {
    for (std::size_t c = 0; c < cells.size(); ++c) {
      table.columns[c].push_back(cells[c]);
      if (std::isnan(cells[c])) ++table.missing_cells;
    }
    table.line_of_row.push_back(line);
  };
  ReadCsvRowsStream(in, name, sink);
  return table;
}

bool ReadCsvRecord(std::istream& in, const std::string& name, long* line_no, std::vector<std::string>* cells) {
  std::string line;
  bool lone_cr = false;
  const CsvLimits limits;
  if (!ReadLine(in, line, name, *line_no + 1, &lone_cr, limits.line)) return false;
  ++*line_no;
  ReadRecord(in, name, line, lone_cr, line_no, cells, limits);
  return true;
}

}  // namespace hysid
