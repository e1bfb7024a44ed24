#include "core/io/csv.hpp"

#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <system_error>

#include "core/io/files.hpp"
#include "core/io/limits.hpp"

namespace hysid {

CsvWriter::CsvWriter(const std::filesystem::path& path, const std::vector<std::string>& header)
    : path_(path), columns_(header.size()) {
  if (path_.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(path_.parent_path(), ec);
    if (ec) {
      throw std::runtime_error(
          fmt::format("{}: cannot create the directory: {}", path_.parent_path().string(), ec.message()));
    }
  }
  tmp_path_ = path_;
  tmp_path_ += ".tmp";
  file_ = std::fopen(tmp_path_.c_str(), "wb");
  if (!file_) throw std::runtime_error(IoError(tmp_path_, "cannot open for writing", errno));
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (i) buffer_.push_back(',');
    fmt::format_to(std::back_inserter(buffer_), "{}", header[i]);
  }
  buffer_.push_back('\n');
}

CsvWriter::~CsvWriter() {
  if (file_) std::fclose(file_);
  if (!published_) ::unlink(tmp_path_.c_str());
}

void CsvWriter::Fail(const char* what, int error_number) {
  if (file_) std::fclose(file_);
  file_ = nullptr;
  ::unlink(tmp_path_.c_str());
  throw std::runtime_error(IoError(tmp_path_, what, error_number));
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
    buffer_.append(cells[i]);
  }
  buffer_.push_back('\n');
  FlushIfLarge();
}

void CsvWriter::FlushIfLarge() {
  if (buffer_.size() < (1u << 16)) return;
  errno = 0;
  if (std::fwrite(buffer_.data(), 1, buffer_.size(), file_) != buffer_.size()) Fail("write failed", errno);
  buffer_.clear();
}

void CsvWriter::Close() {
  if (!file_) throw std::logic_error(fmt::format("{}: closed twice", tmp_path_.string()));
  errno = 0;
  if (std::fwrite(buffer_.data(), 1, buffer_.size(), file_) != buffer_.size()) Fail("write failed", errno);
  buffer_.clear();
  errno = 0;
  if (std::fflush(file_) != 0) Fail("write failed", errno);
  std::FILE* f = file_;
  file_ = nullptr;
  errno = 0;
  if (std::fclose(f) != 0) Fail("write failed (close)", errno);
}

void CsvWriter::Publish() {
  if (file_ || published_) throw std::logic_error(fmt::format("{}: Publish before Close", path_.string()));
  if (std::rename(tmp_path_.c_str(), path_.c_str()) != 0) {
    const int e = errno;
    ::unlink(tmp_path_.c_str());
    throw std::runtime_error(IoError(path_, "cannot rename the temporary file onto it", e));
  }
  published_ = true;
}

int CsvTable::Find(const std::string& name) const {
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i] == name) return static_cast<int>(i);
  }
  return -1;
}

bool ReadBoundedLine(std::istream& in, std::string& line, const std::string& name, long line_no) {
  line.clear();
  const auto max = static_cast<std::size_t>(LimitValue(kMaxCsvLine));
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
    if (line.size() >= max) {
      throw std::invalid_argument(
          fmt::format("{}:{}: the line is longer than the limit of {} {} (raise it with {}=N)", name, line_no,
                      max, kMaxCsvLine.what, kMaxCsvLine.variable));
    }
    line.push_back(static_cast<char>(c));
  }
}

namespace {

std::string_view Trim(std::string_view s) {
  std::size_t b = 0, e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r')) --e;
  return s.substr(b, e - b);
}

// Splits on commas; every cell is checked against the cell limit before it is copied.
std::vector<std::string> Split(std::string_view line, const std::string& name, long line_no) {
  const auto max = static_cast<std::size_t>(LimitValue(kMaxCsvCell));
  std::vector<std::string> cells;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    const std::string_view cell =
        Trim(line.substr(start, comma == std::string_view::npos ? comma : comma - start));
    if (cell.size() > max) {
      throw std::invalid_argument(fmt::format(
          "{}:{}: column {}: the cell '{}' is longer than the limit of {} {} (raise it with {}=N)", name,
          line_no, cells.size() + 1, Abbreviated(cell, 40), max, kMaxCsvCell.what, kMaxCsvCell.variable));
    }
    cells.emplace_back(cell);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return cells;
}

bool ParseNumber(const std::string& cell, double* value) {
  const char* first = cell.data();
  const char* last = cell.data() + cell.size();
  if (!cell.empty() && *first == '+') ++first;
  const auto [end, ec] = std::from_chars(first, last, *value);
  return !cell.empty() && ec == std::errc() && end == last;
}

void CheckHeader(const CsvTable& table, long line_no) {
  bool all_numbers = true;
  for (std::size_t c = 0; c < table.header.size(); ++c) {
    const std::string& h = table.header[c];
    if (h.empty()) {
      throw std::invalid_argument(
          fmt::format("{}:{}: column {} of the header is empty", table.path, line_no, c + 1));
    }
    if (h.find_first_of("\"'") != std::string::npos) {
      throw std::invalid_argument(
          fmt::format("{}:{}: column {} of the header ({}) is quoted; hysid reads plain CSV: write the names "
                      "without quotes",
                      table.path, line_no, c + 1, Abbreviated(h, 40)));
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

}  // namespace

CsvTable ReadCsv(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument(IoError(path, "cannot open file", errno));
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw std::invalid_argument(fmt::format("{}: is a directory, expected a CSV file", path.string()));
  }
  return ReadCsvStream(in, path.string());
}

CsvTable ReadCsvStream(std::istream& in, const std::string& name) {
  CsvTable table;
  table.path = name;
  std::string line;
  long line_no = 0;
  bool have_header = false;
  while (ReadBoundedLine(in, line, name, line_no + 1)) {
    ++line_no;
    const std::string_view trimmed = Trim(line);
    if (trimmed.empty() || trimmed[0] == '#') continue;
    if (!have_header) {
      table.header = Split(trimmed, name, line_no);
      CheckHeader(table, line_no);
      table.columns.assign(table.header.size(), {});
      have_header = true;
      continue;
    }
    const std::vector<std::string> cells = Split(trimmed, name, line_no);
    if (cells.size() != table.header.size()) {
      throw std::invalid_argument(fmt::format("{}:{}: {} cells, the header has {} columns", table.path,
                                              line_no, cells.size(), table.header.size()));
    }
    for (std::size_t c = 0; c < cells.size(); ++c) {
      double value = 0.0;
      if (!ParseNumber(cells[c], &value)) {
        throw std::invalid_argument(fmt::format("{}:{}: column {} ('{}'): '{}' is not a number", table.path,
                                                line_no, c + 1, table.header[c], Abbreviated(cells[c])));
      }
      if (!std::isfinite(value)) {
        throw std::invalid_argument(fmt::format("{}:{}: column {} ('{}'): '{}' is not finite", table.path,
                                                line_no, c + 1, table.header[c], Abbreviated(cells[c])));
      }
      table.columns[c].push_back(value);
    }
    table.line_of_row.push_back(line_no);
  }
  if (!have_header) throw std::invalid_argument(fmt::format("{}: file is empty", table.path));
  return table;
}

}  // namespace hysid
