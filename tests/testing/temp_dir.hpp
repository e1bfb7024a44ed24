// A fresh scratch directory for a test, unique per process: test binaries of several build trees,
// or of one `ctest -j`, never share (and never delete) each other's files.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>
#include <string_view>

namespace hysid::testing {

// <temp>/hysid-test-<pid>-<name>, emptied and created.
inline std::filesystem::path FreshTempDir(std::string_view name) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("hysid-test-" + std::to_string(::getpid()) + "-" + std::string(name));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace hysid::testing
