#include "core/io/csv.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <stdexcept>
#include <system_error>

namespace hysid {

CsvWriter::CsvWriter(const std::filesystem::path& path, const std::vector<std::string>& header)
    : path_(path), columns_(header.size()) {
  if (path_.has_parent_path()) std::filesystem::create_directories(path_.parent_path());
  tmp_path_ = path_;
  tmp_path_ += ".tmp";
  file_ = std::fopen(tmp_path_.c_str(), "wb");
  if (!file_) {
    throw std::runtime_error(fmt::format("{}: cannot open for writing", tmp_path_.string()));
  }
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (i) buffer_.push_back(',');
    fmt::format_to(std::back_inserter(buffer_), "{}", header[i]);
  }
  buffer_.push_back('\n');
}

CsvWriter::~CsvWriter() {
  if (file_) {
    std::fclose(file_);
    std::error_code ec;
    std::filesystem::remove(tmp_path_, ec);
  }
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
  if (std::fwrite(buffer_.data(), 1, buffer_.size(), file_) != buffer_.size()) {
    throw std::runtime_error(fmt::format("{}: write failed", tmp_path_.string()));
  }
  buffer_.clear();
}

void CsvWriter::Commit() {
  const bool ok = std::fwrite(buffer_.data(), 1, buffer_.size(), file_) == buffer_.size();
  buffer_.clear();
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!ok || !closed) throw std::runtime_error(fmt::format("{}: write failed", path_.string()));
  std::filesystem::rename(tmp_path_, path_);
}

int CsvTable::Find(const std::string& name) const {
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i] == name) return static_cast<int>(i);
  }
  return -1;
}

namespace {

std::string Trim(std::string_view s) {
  std::size_t b = 0, e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r')) --e;
  return std::string(s.substr(b, e - b));
}

std::vector<std::string> Split(const std::string& line) {
  std::vector<std::string> cells;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    cells.push_back(Trim(std::string_view(line).substr(start, comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return cells;
}

}  // namespace

CsvTable ReadCsv(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(fmt::format("{}: cannot open file", path.string()));
  CsvTable table;
  table.path = path.string();
  std::string line;
  long line_no = 0;
  bool have_header = false;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string trimmed = Trim(line);
    if (trimmed.empty() || trimmed[0] == '#') continue;
    if (!have_header) {
      table.header = Split(trimmed);
      for (std::size_t c = 0; c < table.header.size(); ++c) {
        if (table.header[c].empty()) {
          throw std::invalid_argument(fmt::format("{}:{}: column {} of the header is empty",
                                                  table.path, line_no, c + 1));
        }
      }
      table.columns.assign(table.header.size(), {});
      have_header = true;
      continue;
    }
    const std::vector<std::string> cells = Split(trimmed);
    if (cells.size() != table.header.size()) {
      throw std::invalid_argument(fmt::format("{}:{}: {} cells, the header has {} columns",
                                              table.path, line_no, cells.size(),
                                              table.header.size()));
    }
    for (std::size_t c = 0; c < cells.size(); ++c) {
      const std::string& cell = cells[c];
      double value = 0.0;
      const char* first = cell.data();
      const char* last = cell.data() + cell.size();
      if (!cell.empty() && *first == '+') ++first;
      const auto [end, ec] = std::from_chars(first, last, value);
      if (cell.empty() || ec != std::errc() || end != last) {
        throw std::invalid_argument(fmt::format("{}:{}: column {} ('{}'): '{}' is not a number",
                                                table.path, line_no, c + 1, table.header[c],
                                                cell));
      }
      if (!std::isfinite(value)) {
        throw std::invalid_argument(fmt::format("{}:{}: column {} ('{}'): '{}' is not finite",
                                                table.path, line_no, c + 1, table.header[c],
                                                cell));
      }
      table.columns[c].push_back(value);
    }
    table.line_of_row.push_back(line_no);
  }
  if (!have_header) throw std::invalid_argument(fmt::format("{}: file is empty", table.path));
  return table;
}

}  // namespace hysid
