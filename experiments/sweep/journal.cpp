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

std::string JoinCsvLine(const std::vector<std::string>& cells) { return JoinCsvRecord(cells); }

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
  const std::string text = ReadWholeFile(path_, "journal");
  std::size_t pos = 0, keep = 0;  // keep: bytes of complete, valid records
  long line_no = 0, record_no = 0;
  std::vector<std::string> cells;
  while (pos < text.size()) {
    // One record: lines are joined while a quoted cell (a name with a line break) is open.
    const long first_line = line_no + 1;
    std::size_t end = pos;
    bool complete = false;
    if (record_no == 0) {  // the identity line, compared as it is (a foreign first line may hold a quote)
      const std::size_t nl = text.find('\n');
      if (nl != std::string::npos) {
        ++line_no;
        end = nl + 1;
        complete = true;
      }
    }
    while (!complete) {
      const std::size_t nl = text.find('\n', end);
      if (nl == std::string::npos) break;  // a torn last record: dropped
      ++line_no;
      end = nl + 1;
      complete = SplitCsvRecord(std::string_view(text).substr(pos, nl - pos), path_.string(), first_line, &cells);
    }
    if (!complete) break;
    const std::string record = text.substr(pos, end - 1 - pos);
    ++record_no;
    if (record_no == 1 && record != identity) {
      throw std::invalid_argument(fmt::format(
          "{}:1: the journal is of another sweep or shard ('{}', this run is '{}'); use another --out, or "
          "delete the directory",
          path_.string(), Abbreviated(record, 80), identity));
    }
    if (record_no == 2 && record != head) {
      throw std::invalid_argument(fmt::format(
          "{}:{}: the journal's columns differ from this sweep's (another hysid version?); use another --out, "
          "or delete the directory",
          path_.string(), first_line));
    }
    if (record_no > 2) AddRow(record, first_line);
    pos = end;
    keep = pos;
  }
  if (record_no < 2) {  // not even a complete header: start over
    std::filesystem::remove(path_);
    recovered_.clear();
    lines_.clear();
  } else if (keep < text.size()) {
    std::filesystem::resize_file(path_, keep);
  }
}

void Journal::AddRow(const std::string& line, long line_no) {
  std::vector<std::string> cells;
  SplitCsvRecord(line, path_.string(), line_no, &cells);
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
