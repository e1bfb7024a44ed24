// Input files read whole; output files checked before a computation, written under a temporary name
// and renamed.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace hysid {

// Throws std::invalid_argument "`label` PATH: ..." unless PATH can be written as a file: not a
// directory, its directory exists (or is created here) and is writable. `label` names the flag or
// key, e.g. "--trace".
void CheckOutputPath(const std::string& label, const std::filesystem::path& path);

// The same for a directory that will hold outputs (created here when missing).
void CheckOutputDirectory(const std::string& label, const std::filesystem::path& dir);

// Writes `text` to PATH.tmp and renames it onto PATH; the temporary is removed on every failure.
// Throws std::runtime_error "PATH.tmp: write failed: <strerror>".
void WriteFileAtomically(const std::filesystem::path& path, std::string_view text);

// The whole of an input file (a model file, a sweep file). Throws std::invalid_argument
// "PATH: cannot read the WHAT: <strerror(errno)>", and for a file that is not a regular file
// (CheckRegularFile) or is longer than the limit kMaxInputFile (core/io/limits.hpp).
std::string ReadWholeFile(const std::filesystem::path& path, const char* what);

// "PATH: WHAT: <strerror(errno)>", or "...: short write" when errno is 0.
std::string IoError(const std::filesystem::path& path, const char* what, int error_number);

}  // namespace hysid
