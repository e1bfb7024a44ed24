#include "experiments/sweep/journal.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>

namespace hysid {

std::vector<std::string> SplitCsvLine(const std::string& line) {
  std::vector<std::string> cells;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    if (comma == std::string::npos) {
      cells.push_back(line.substr(start));
      return cells;
    }
    cells.push_back(line.substr(start, comma - start));
    start = comma + 1;
  }
}

std::string JoinCsvLine(const std::vector<std::string>& cells) {
  std::string s;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (i) s.push_back(',');
    s += cells[i];
  }
  return s;
}

Journal::Journal(const std::filesystem::path& path, const std::vector<std::string>& header)
    : path_(path), columns_(header.size()) {
  const std::string head = JoinCsvLine(header);
  std::uintmax_t keep = 0;  // bytes of complete, valid content
  if (std::filesystem::exists(path_)) {
    std::ifstream in(path_, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string text = ss.str();
    std::size_t pos = 0;
    long line_no = 0;
    while (pos < text.size()) {
      const std::size_t nl = text.find('\n', pos);
      ++line_no;
      if (nl == std::string::npos) {  // torn last line: dropped
        ++dropped_;
        break;
      }
      const std::string line = text.substr(pos, nl - pos);
      if (line_no == 1) {
        if (line != head) {
          throw std::invalid_argument(fmt::format(
              "{}:1: the journal's columns differ from this sweep's; it belongs to another sweep or version "
              "(use another --out, or delete the directory)",
              path_.string()));
        }
      } else {
        std::vector<std::string> cells = SplitCsvLine(line);
        long unit = -1;
        try {
          std::size_t used = 0;
          unit = cells.empty() ? -1 : std::stol(cells[0], &used);
          if (used != cells[0].size()) unit = -1;
        } catch (const std::exception&) {
          unit = -1;
        }
        if (cells.size() != columns_ || unit < 0) {
          throw std::invalid_argument(fmt::format("{}:{}: malformed journal row ({} cells, expected {})",
                                                  path_.string(), line_no, cells.size(), columns_));
        }
        recovered_.emplace(unit, std::move(cells));  // a duplicate keeps the first
      }
      pos = nl + 1;
      keep = pos;
    }
    if (keep == 0) {  // not even a complete header: start over
      std::filesystem::remove(path_);
    } else if (keep < text.size()) {
      std::filesystem::resize_file(path_, keep);
    }
  }
  const bool fresh = !std::filesystem::exists(path_);
  fd_ = ::open(path_.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) {
    throw std::runtime_error(fmt::format("{}: cannot open the journal: {}", path_.string(), std::strerror(errno)));
  }
  if (fresh) {
    const std::string line = head + "\n";
    if (::write(fd_, line.data(), line.size()) != static_cast<ssize_t>(line.size())) {
      throw std::runtime_error(fmt::format("{}: write failed: {}", path_.string(), std::strerror(errno)));
    }
  }
}

Journal::~Journal() {
  if (fd_ >= 0) {
    ::fsync(fd_);
    ::close(fd_);
  }
}

void Journal::Append(const std::vector<std::string>& cells) {
  if (cells.size() != columns_) {
    throw std::logic_error(fmt::format("journal row has {} cells, expected {}", cells.size(), columns_));
  }
  const std::string line = JoinCsvLine(cells) + "\n";
  const std::lock_guard lock(mutex_);
  if (::write(fd_, line.data(), line.size()) != static_cast<ssize_t>(line.size())) {
    throw std::runtime_error(fmt::format("{}: write failed: {}", path_.string(), std::strerror(errno)));
  }
}

}  // namespace hysid
