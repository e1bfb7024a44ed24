// A fresh scratch directory for a test, unique per process: test binaries of several build trees,
// or of one `ctest -j`, never share (and never delete) each other's files. The directories a
// process made are removed when it exits, unless HYSID_KEEP_TEST_FILES is set (to look at them
// after a failure).
#pragma once

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace hysid::testing {

namespace detail {

// The directories this process made, removed at its exit.
class TempDirRegistry {
 public:
  TempDirRegistry(const TempDirRegistry&) = delete;
  TempDirRegistry& operator=(const TempDirRegistry&) = delete;

  static TempDirRegistry& Instance() {
    static TempDirRegistry registry;
    return registry;
  }

  void Add(const std::filesystem::path& dir) {
    const std::scoped_lock lock(mutex_);
    dirs_.push_back(dir);
  }

  ~TempDirRegistry() {
    // A forked child that exits normally leaves its parent's directories alone.
    if (std::getenv("HYSID_KEEP_TEST_FILES") != nullptr || ::getpid() != owner_) return;
    for (const auto& dir : dirs_) {
      std::error_code ignored;
      std::filesystem::remove_all(dir, ignored);
    }
  }

 private:
  TempDirRegistry() = default;

  const pid_t owner_ = ::getpid();
  std::mutex mutex_;
  std::vector<std::filesystem::path> dirs_;
};

}  // namespace detail

// <temp>/hysid-test-<pid>-<name>, emptied and created; removed when the process exits.
inline std::filesystem::path FreshTempDir(std::string_view name) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("hysid-test-" + std::to_string(::getpid()) + "-" + std::string(name));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  detail::TempDirRegistry::Instance().Add(dir);
  return dir;
}

}  // namespace hysid::testing
