#include "core/io/files.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <system_error>

#include <fmt/format.h>

#include "core/io/limits.hpp"

namespace hysid {

namespace fs = std::filesystem;

std::string ReadWholeFile(const fs::path& path, const char* what) {
  CheckRegularFile(path.string(), what);
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument(IoError(path, fmt::format("cannot read the {}", what).c_str(), errno));
  // In chunks, stopping one chunk past the limit (the file's size may change while it is read).
  const auto max = static_cast<std::size_t>(LimitValue(kMaxInputFile));
  std::string text;
  char chunk[1 << 16];
  while (text.size() <= max && in.read(chunk, sizeof chunk).gcount() > 0) {
    text.append(chunk, static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad()) {
    throw std::invalid_argument(IoError(path, fmt::format("cannot read the {}", what).c_str(), errno));
  }
  if (text.size() > max) {
    throw std::invalid_argument(
        fmt::format("{}: the {} is longer than the limit of {} {} (raise it with {}=N)", path.string(), what,
                    max, kMaxInputFile.what, kMaxInputFile.variable));
  }
  return text;
}

std::string IoError(const fs::path& path, const char* what, int error_number) {
  return fmt::format("{}: {}: {}", path.string(), what,
                     error_number ? std::strerror(error_number) : "short write (no error reported)");
}

void CheckOutputDirectory(const std::string& label, const fs::path& dir) {
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) {
    throw std::invalid_argument(fmt::format("{} {}: exists and is not a directory", label, dir.string()));
  }
  if (!fs::exists(dir, ec)) {
    fs::create_directories(dir, ec);
    if (ec) {
      throw std::invalid_argument(
          fmt::format("{} {}: cannot create the directory: {}", label, dir.string(), ec.message()));
    }
  }
  if (::access(dir.c_str(), W_OK | X_OK) != 0) {
    throw std::invalid_argument(
        fmt::format("{} {}: not writable: {}", label, dir.string(), std::strerror(errno)));
  }
}

void CheckOutputPath(const std::string& label, const fs::path& path) {
  if (path.empty()) throw std::invalid_argument(fmt::format("{}: empty path", label));
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    throw std::invalid_argument(
        fmt::format("{} {}: is a directory, expected a file name", label, path.string()));
  }
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  CheckOutputDirectory(label, dir);
  if (fs::exists(path, ec) && !fs::is_regular_file(path, ec)) {
    throw std::invalid_argument(fmt::format("{} {}: exists and is not a regular file", label, path.string()));
  }
}

void WriteFileAtomically(const fs::path& path, std::string_view text) {
  fs::path tmp = path;
  tmp += ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error(IoError(tmp, "cannot open for writing", errno));
  std::size_t done = 0;
  int error = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      error = n < 0 ? errno : ENOSPC;
      break;
    }
    done += static_cast<std::size_t>(n);
  }
  if (::close(fd) != 0 && error == 0) error = errno ? errno : EIO;
  if (error == 0 && std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int e = errno;
    ::unlink(tmp.c_str());
    throw std::runtime_error(IoError(path, "cannot rename the temporary file onto it", e));
  }
  if (error != 0) {
    ::unlink(tmp.c_str());
    throw std::runtime_error(IoError(tmp, "write failed", error));
  }
}

}  // namespace hysid
