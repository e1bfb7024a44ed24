// Input files read whole; output files checked before a computation (never one of the run's inputs),
// written under a temporary name in their directory and renamed.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace hysid {

// The files a run reads (data, sidecars, model and sweep files), each with the flag or key that
// names it. An output that is one of them is refused before anything is written.
class InputFiles {
 public:
  // Records `path` when it exists (a missing input is its reader's error, not this one's).
  void Add(const std::string& label, const std::filesystem::path& path);
  // Throws std::invalid_argument "`label` PATH: is the input `input label` INPUT; ..." when PATH is
  // one of the inputs: the same (device, inode) — a hard link or a symbolic link to it included —
  // or the same resolved path.
  void CheckNotInput(const std::string& label, const std::filesystem::path& path) const;

 private:
  struct Input {
    std::string label;
    std::filesystem::path path, resolved;
    unsigned long long device = 0, inode = 0;
  };
  std::vector<Input> inputs_;
};

// Throws std::invalid_argument "`label` PATH: ..." unless PATH can be written as a file: not a
// directory, its directory exists (or is created here) and is writable, and not one of `inputs`.
// `label` names the flag or key, e.g. "--trace".
void CheckOutputPath(const std::string& label, const std::filesystem::path& path,
                     const InputFiles& inputs = {});

// A set of outputs written by one run (label, path): each checked as CheckOutputPath does, and no
// two the same file (compared as resolved paths), e.g. "--hulls t.csv: the same file as --trace t.csv".
void CheckOutputPaths(const std::vector<std::pair<std::string, std::filesystem::path>>& outputs,
                      const InputFiles& inputs = {});

// The same for a directory that will hold outputs (created here when missing).
void CheckOutputDirectory(const std::string& label, const std::filesystem::path& dir);

// One output file written under a temporary name beside it (PATH.<pid>-<n>.tmp, created exclusively)
// and renamed onto PATH by Publish(), so PATH holds either its old content or the whole new one.
// Every failure throws std::runtime_error "PATH: <what>: <strerror>" and removes the temporary file;
// so does the destructor of a file not published, and a signal that ends the process
// (core/io/signals.hpp: the temporary file is registered there until it is renamed or removed).
class AtomicFile {
 public:
  explicit AtomicFile(const std::filesystem::path& path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  void Write(std::string_view text);
  // Writes are checked, then the file is closed (its close checked too).
  void Close();
  // Renames the closed temporary file onto the path.
  void Publish();
  const std::filesystem::path& path() const { return path_; }
  bool closed() const { return fd_ < 0; }

 private:
  [[noreturn]] void Fail(const char* what, int error_number);
  std::filesystem::path path_, tmp_;
  int fd_ = -1;
  bool published_ = false;
  int signal_slot_ = -1;  // RegisterTemporaryFile's slot
};

// Writes `text` to PATH through an AtomicFile.
void WriteFileAtomically(const std::filesystem::path& path, std::string_view text);

// Flushes standard output and reports whether everything written to it arrived; on failure the
// message "standard output: write failed: <strerror>" goes to *error.
bool FlushStandardOutput(std::string* error);

// The whole of an input file (a model file, a sweep file). Throws std::invalid_argument
// "PATH: cannot read the WHAT: <strerror(errno)>", and for a file that is not a regular file
// (CheckRegularFile) or is longer than the limit kMaxInputFile (core/io/limits.hpp).
std::string ReadWholeFile(const std::filesystem::path& path, const char* what);

// "PATH: WHAT: <strerror(errno)>", or "...: short write" when errno is 0.
std::string IoError(const std::filesystem::path& path, const char* what, int error_number);

}  // namespace hysid
