#include "core/io/files.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <system_error>

#include <fmt/format.h>

#include "core/io/limits.hpp"
#include "core/io/signals.hpp"

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

namespace {

// The absolute path with symbolic links resolved as far as the path exists.
fs::path Resolved(const fs::path& path) {
  std::error_code ec;
  fs::path r = fs::weakly_canonical(fs::absolute(path, ec), ec);
  return ec ? fs::absolute(path, ec).lexically_normal() : r;
}

}  // namespace

void InputFiles::Add(const std::string& label, const fs::path& path) {
  struct stat st {};
  if (path.empty() || ::stat(path.c_str(), &st) != 0) return;
  inputs_.push_back({label, path, Resolved(path), static_cast<unsigned long long>(st.st_dev),
                     static_cast<unsigned long long>(st.st_ino)});
}

void InputFiles::CheckNotInput(const std::string& label, const fs::path& path) const {
  struct stat st {};
  const bool exists = ::stat(path.c_str(), &st) == 0;
  const fs::path resolved = Resolved(path);
  for (const Input& in : inputs_) {
    const bool same_file = exists && static_cast<unsigned long long>(st.st_dev) == in.device &&
                           static_cast<unsigned long long>(st.st_ino) == in.inode;
    if (!same_file && resolved != in.resolved) continue;
    throw std::invalid_argument(
        fmt::format("{} {}: is the input {} {}{}; an output never replaces an input of the same run: give "
                    "another name",
                    label, path.string(), in.label, in.path.string(),
                    resolved == in.resolved ? "" : " (the same file through a link)"));
  }
}

namespace {

// The nearest of dir and its ancestors that exists ("." for a relative path none of whose parts
// exists).
fs::path NearestExisting(const fs::path& dir) {
  std::error_code ec;
  fs::path p = dir;
  while (!p.empty() && !fs::exists(p, ec)) {
    if (!p.has_parent_path() || p.parent_path() == p) return ".";
    p = p.parent_path();
  }
  return p.empty() ? fs::path(".") : p;
}

// dir is a writable directory, or the directories missing on its way can be created: its nearest
// existing ancestor is a writable directory. Creates nothing.
void CheckDirectoryWritable(const std::string& label, const fs::path& dir) {
  std::error_code ec;
  const fs::path at = NearestExisting(dir);
  if (!fs::is_directory(at, ec)) {
    throw std::invalid_argument(fmt::format("{} {}: exists and is not a directory", label, at.string()));
  }
  if (::access(at.c_str(), W_OK | X_OK) != 0) {
    const int e = errno;
    throw std::invalid_argument(at == dir ? fmt::format("{} {}: not writable: {}", label, dir.string(), std::strerror(e))
                                          : fmt::format("{} {}: cannot create the directory: {}", label,
                                                        dir.string(), std::strerror(e)));
  }
}

void CreateDirectory(const std::string& label, const fs::path& dir) {
  std::error_code ec;
  if (fs::exists(dir, ec)) return;
  fs::create_directories(dir, ec);
  if (ec) {
    throw std::invalid_argument(
        fmt::format("{} {}: cannot create the directory: {}", label, dir.string(), ec.message()));
  }
}

fs::path DirectoryOf(const fs::path& path) { return path.has_parent_path() ? path.parent_path() : fs::path("."); }

// CheckOutputPath without creating the directory.
void CheckOutputFile(const std::string& label, const fs::path& path, const InputFiles& inputs) {
  if (path.empty()) throw std::invalid_argument(fmt::format("{}: empty path", label));
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    throw std::invalid_argument(
        fmt::format("{} {}: is a directory, expected a file name", label, path.string()));
  }
  inputs.CheckNotInput(label, path);
  CheckDirectoryWritable(label, DirectoryOf(path));
  if (fs::exists(path, ec) && !fs::is_regular_file(path, ec)) {
    throw std::invalid_argument(fmt::format("{} {}: exists and is not a regular file", label, path.string()));
  }
}

}  // namespace

void CheckOutputDirectory(const std::string& label, const fs::path& dir) {
  CheckDirectoryWritable(label, dir);
  CreateDirectory(label, dir);
}

void CheckOutputPath(const std::string& label, const fs::path& path, const InputFiles& inputs) {
  CheckOutputFile(label, path, inputs);
  CreateDirectory(label, DirectoryOf(path));
}

// Every output checked before any directory is created, so that a refused set leaves nothing behind.
void CheckOutputPaths(const std::vector<std::pair<std::string, fs::path>>& outputs, const InputFiles& inputs) {
  for (std::size_t a = 0; a < outputs.size(); ++a) {
    CheckOutputFile(outputs[a].first, outputs[a].second, inputs);
    for (std::size_t b = 0; b < a; ++b) {
      if (Resolved(outputs[a].second) != Resolved(outputs[b].second)) continue;
      throw std::invalid_argument(fmt::format("{} {}: the same file as {} {}; give each output its own name",
                                              outputs[a].first, outputs[a].second.string(), outputs[b].first,
                                              outputs[b].second.string()));
    }
  }
  for (const auto& [label, path] : outputs) CreateDirectory(label, DirectoryOf(path));
}

AtomicFile::AtomicFile(const fs::path& path) : path_(path) {
  static std::atomic<unsigned> counter{0};
  int error = 0;
  for (int attempt = 0; attempt < 100 && fd_ < 0; ++attempt) {
    tmp_ = path_;
    tmp_ += fmt::format(".{}-{}.tmp", ::getpid(), counter.fetch_add(1));
    // Registered before it exists, so a signal never finds it created but unregistered.
    signal_slot_ = RegisterTemporaryFile(tmp_.string());  // removed on SIGINT/SIGTERM/SIGHUP/SIGPIPE
    fd_ = ::open(tmp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    error = fd_ < 0 ? errno : 0;
    if (fd_ < 0) {
      ReleaseTemporaryFile(signal_slot_);
      signal_slot_ = -1;
    }
    if (fd_ < 0 && error != EEXIST) break;
  }
  if (fd_ < 0) throw std::runtime_error(IoError(path_, "cannot create a temporary file beside it", error));
}

AtomicFile::~AtomicFile() {
  if (fd_ >= 0) ::close(fd_);
  if (!published_) ::unlink(tmp_.c_str());
  ReleaseTemporaryFile(signal_slot_);
}

void AtomicFile::Fail(const char* what, int error_number) {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  ::unlink(tmp_.c_str());
  throw std::runtime_error(IoError(path_, what, error_number));
}

void AtomicFile::Write(std::string_view text) {
  if (fd_ < 0) throw std::logic_error(fmt::format("{}: written after Close", path_.string()));
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd_, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) Fail("write failed", n < 0 ? errno : ENOSPC);
    done += static_cast<std::size_t>(n);
  }
}

void AtomicFile::Close() {
  if (fd_ < 0) throw std::logic_error(fmt::format("{}: closed twice", path_.string()));
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) {
    const int e = errno;
    ::unlink(tmp_.c_str());
    throw std::runtime_error(IoError(path_, "write failed (close)", e));
  }
}

void AtomicFile::Publish() {
  if (fd_ >= 0 || published_) throw std::logic_error(fmt::format("{}: Publish before Close", path_.string()));
  if (std::rename(tmp_.c_str(), path_.c_str()) != 0) {
    const int e = errno;
    ::unlink(tmp_.c_str());
    throw std::runtime_error(IoError(path_, "cannot rename the temporary file onto it", e));
  }
  published_ = true;
  ReleaseTemporaryFile(signal_slot_);
  signal_slot_ = -1;
}

void WriteFileAtomically(const fs::path& path, std::string_view text) {
  AtomicFile file(path);
  file.Write(text);
  file.Close();
  file.Publish();
}

bool FlushStandardOutput(std::string* error) {
  errno = 0;
  const bool flushed = std::fflush(stdout) == 0;
  const int e = errno;
  if (flushed && !std::ferror(stdout)) return true;
  *error = IoError("standard output", "write failed", e ? e : EIO);
  return false;
}

}  // namespace hysid
