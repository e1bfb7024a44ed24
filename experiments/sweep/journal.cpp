#include "experiments/sweep/journal.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>

#include "core/io/csv.hpp"
#include "core/io/files.hpp"
#include "core/io/limits.hpp"

namespace hysid {

std::string JoinCsvLine(const std::vector<std::string>& cells) {
  std::string s;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (i) s.push_back(',');
    s += cells[i];
  }
  return s;
}

namespace {

void WriteAll(int fd, const std::string& text, const std::filesystem::path& path) {
  errno = 0;
  if (::write(fd, text.data(), text.size()) != static_cast<ssize_t>(text.size())) {
    throw std::runtime_error(IoError(path, "write failed", errno));
  }
}

}  // namespace

Journal::Journal(const std::filesystem::path& path, const std::vector<std::string>& header,
                 const std::string& hash, const std::string& shard)
    : path_(path), hash_(hash), columns_(header.size()) {
  const std::string identity = fmt::format("# hysid journal sweep={} shard={}", hash, shard);
  std::vector<std::string> full = header;
  full.push_back("sweep");
  const std::string head = JoinCsvLine(full);
  if (std::filesystem::exists(path_)) ReadExisting(identity, head);
  const bool fresh = !std::filesystem::exists(path_);
  fd_ = ::open(path_.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw std::runtime_error(IoError(path_, "cannot open the journal", errno));
  if (fresh) WriteAll(fd_, identity + "\n" + head + "\n", path_);
}

void Journal::ReadExisting(const std::string& identity, const std::string& head) {
  std::ifstream in(path_, std::ios::binary);
  if (!in) throw std::invalid_argument(IoError(path_, "cannot open the journal", errno));
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  std::size_t pos = 0, keep = 0;  // keep: bytes of complete, valid content
  long line_no = 0, complete = 0;
  while (pos < text.size()) {
    const std::size_t nl = text.find('\n', pos);
    ++line_no;
    if (nl == std::string::npos) break;  // a torn last line: dropped
    const std::string line = text.substr(pos, nl - pos);
    if (line_no == 1 && line != identity) {
      throw std::invalid_argument(fmt::format(
          "{}:1: the journal is of another sweep or shard ('{}', this run is '{}'); use another --out, or "
          "delete the directory",
          path_.string(), Abbreviated(line, 80), identity));
    }
    if (line_no == 2 && line != head) {
      throw std::invalid_argument(fmt::format(
          "{}:2: the journal's columns differ from this sweep's (another hysid version?); use another --out, "
          "or delete the directory",
          path_.string()));
    }
    if (line_no > 2) AddRow(line, line_no);
    pos = nl + 1;
    keep = pos;
    ++complete;
  }
  if (complete < 2) {  // not even a complete header: start over
    std::filesystem::remove(path_);
    recovered_.clear();
    lines_.clear();
  } else if (keep < text.size()) {
    std::filesystem::resize_file(path_, keep);
  }
}

void Journal::AddRow(const std::string& line, long line_no) {
  std::vector<std::string> cells = SplitCsvLine(line, path_.string(), line_no);
  long unit = -1;
  try {
    std::size_t used = 0;
    unit = std::stol(cells[0], &used);
    if (used != cells[0].size()) unit = -1;
  } catch (const std::exception&) {
    unit = -1;
  }
  if (cells.size() != columns_ + 1 || unit < 0) {
    throw std::invalid_argument(fmt::format("{}:{}: malformed journal row ({} cells, expected {}): '{}'",
                                            path_.string(), line_no, cells.size(), columns_ + 1,
                                            Abbreviated(line, 60)));
  }
  if (cells.back() != hash_) {
    throw std::invalid_argument(
        fmt::format("{}:{}: the row of unit {} belongs to sweep {}, not to this sweep {} (a foreign row); "
                    "use another --out, "
                    "or delete the directory",
                    path_.string(), line_no, unit, Abbreviated(cells.back(), 40), hash_));
  }
  cells.pop_back();
  const auto [it, inserted] = recovered_.emplace(unit, cells);
  if (!inserted) {
    // The last cell is the wall time, which differs between two runs of the same unit.
    if (!std::equal(cells.begin(), cells.end() - 1, it->second.begin(), it->second.end() - 1)) {
      throw std::invalid_argument(fmt::format(
          "{}:{}: unit {} appears again (first on line {}) with different content; the journal is corrupt: "
          "delete the directory and run again",
          path_.string(), line_no, unit, lines_.at(unit)));
    }
    return;
  }
  lines_.emplace(unit, line_no);
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
  const std::string line = JoinCsvLine(cells) + "," + hash_ + "\n";
  const std::lock_guard lock(mutex_);
  WriteAll(fd_, line, path_);
}

DirectoryLock::DirectoryLock(const std::filesystem::path& dir) {
  const std::filesystem::path path = dir / ".lock";
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw std::invalid_argument(IoError(path, "cannot open the lock file", errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int e = errno;
    ::close(fd_);
    fd_ = -1;
    if (e == EWOULDBLOCK) {
      throw std::invalid_argument(fmt::format(
          "{}: another hysid process is running in this directory ({} is locked); wait for it or use another "
          "--out",
          dir.string(), path.string()));
    }
    throw std::invalid_argument(IoError(path, "cannot lock", e));
  }
}

DirectoryLock::~DirectoryLock() {
  if (fd_ >= 0) ::close(fd_);
}

}  // namespace hysid
