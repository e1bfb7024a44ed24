// The append-only record of finished units (DIR/trials.journal) that makes a sweep resumable.
//
// Record 1 names the sweep: "# hysid journal sweep=HASH shard=K/N"; record 2 holds the columns (the
// caller's plus "sweep"); every other record is one unit's row (a record is one line unless a name
// holds a line break; cells are quoted per RFC 4180), its first cell the unit id and its
// last the sweep's hash, appended with a single write(2) on an O_APPEND descriptor, so a kill
// (SIGINT or SIGKILL) leaves at most one torn line at the end.
//
// Opening an existing journal keeps every complete row and cuts a torn tail off the file. It
// refuses, naming the file and line: another sweep's or shard's first line, other columns, a
// malformed line before the end, a row whose hash is another sweep's, and a unit appearing twice
// with different content (all but the last cell, the wall time); an identical duplicate is dropped.
#pragma once

#include <filesystem>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace hysid {

class Journal {
 public:
  Journal(const std::filesystem::path& path, const std::vector<std::string>& header, const std::string& hash,
          const std::string& shard);
  ~Journal();
  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;

  // Rows recovered from an earlier run: unit id → cells (without the hash).
  const std::map<long, std::vector<std::string>>& recovered() const { return recovered_; }
  // The file line a recovered unit was read from.
  long line_of(long unit) const { return lines_.at(unit); }
  const std::filesystem::path& path() const { return path_; }

  // Appends one row (thread-safe). Its first cell is the unit id; the hash is appended here.
  void Append(const std::vector<std::string>& cells);

 private:
  void ReadExisting(const std::string& identity, const std::string& head);
  void AddRow(const std::string& line, long line_no);
  std::filesystem::path path_;
  std::string hash_;
  std::size_t columns_ = 0;  // the caller's, without the hash
  int fd_ = -1;
  std::mutex mutex_;
  std::map<long, std::vector<std::string>> recovered_;
  std::map<long, long> lines_;
};

// An exclusive advisory lock (flock) on DIR/.lock for the lifetime of the object. Throws
// std::invalid_argument naming the directory when another process holds it.
class DirectoryLock {
 public:
  explicit DirectoryLock(const std::filesystem::path& dir);
  ~DirectoryLock();
  DirectoryLock(const DirectoryLock&) = delete;
  DirectoryLock& operator=(const DirectoryLock&) = delete;

 private:
  int fd_ = -1;
};

// One journal record from its cells, each quoted per RFC 4180 when it holds a comma, a quote or a line
// break (a model or parameter name may); read back with SplitCsvRecord (core/io/csv.hpp), lines joined
// while a quoted cell is open.
std::string JoinCsvLine(const std::vector<std::string>& cells);

}  // namespace hysid
