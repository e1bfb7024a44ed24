// The append-only record of finished units (DIR/trials.journal) that makes a sweep resumable.
//
// Line 1 is the header; every other line is one unit's row, appended with a single write(2) on an
// O_APPEND descriptor, so a kill (SIGINT or SIGKILL) leaves at most one torn line at the end. Opening
// an existing journal keeps every complete row, cuts a torn tail off the file, and refuses a journal
// whose header differs or that has a malformed line before its end (naming the file and line).
#pragma once

#include <filesystem>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace hysid {

class Journal {
 public:
  Journal(const std::filesystem::path& path, const std::vector<std::string>& header);
  ~Journal();
  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;

  // Rows recovered from an earlier run: unit id → cells.
  const std::map<long, std::vector<std::string>>& recovered() const { return recovered_; }
  long dropped_torn_lines() const { return dropped_; }

  // Appends one row (thread-safe). Its first cell is the unit id.
  void Append(const std::vector<std::string>& cells);

 private:
  std::filesystem::path path_;
  std::size_t columns_ = 0;
  int fd_ = -1;
  std::mutex mutex_;
  std::map<long, std::vector<std::string>> recovered_;
  long dropped_ = 0;
};

// Splits one CSV line of plain cells (no quoting) on commas.
std::vector<std::string> SplitCsvLine(const std::string& line);
std::string JoinCsvLine(const std::vector<std::string>& cells);

}  // namespace hysid
