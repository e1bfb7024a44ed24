// The signals that end a hysid process (SIGINT, SIGTERM, SIGHUP, SIGPIPE) and the temporary files of
// AtomicFile (core/io/files.hpp) they must not leave behind. This is the library's one process-wide
// state: a signal handler can reach nothing else. Every AtomicFile registers its temporary file here
// while it exists; the handler removes the registered files with unlink(2) (async-signal-safe) and
// ends the process.
#pragma once

#include <string>

namespace hysid {

// Registers a temporary file for removal on a signal; returns its slot, or -1 when the path is longer
// than PATH_MAX or all kMaxTemporaryFiles slots are taken (the file is then not removed on a signal).
int RegisterTemporaryFile(const std::string& path);
// Releases a slot of RegisterTemporaryFile (-1: nothing). Call after the file is renamed or removed.
void ReleaseTemporaryFile(int slot);
// Unlinks every registered temporary file. Async-signal-safe.
void RemoveTemporaryFiles();

// At most this many temporary files at once are removed on a signal.
inline constexpr int kMaxTemporaryFiles = 128;

// Installs the command line's handlers for the signals above (each one whose disposition is not
// SIG_IGN when called, so a signal ignored by the parent, as under nohup, stays ignored). Each
// handler removes the registered temporary files, then:
//  - SIGINT, SIGTERM, SIGHUP: writes "hysid: interrupted by SIGxxx" to stderr and exits with
//    128 + the signal number (130, 143, 129);
//  - SIGPIPE (standard output or an output pipe closed by its reader, as in `hysid … | head -1`):
//    restores the default action and raises the signal again, so the process dies quietly by
//    SIGPIPE as pipeline tools do (the shell shows 141).
// An output renamed onto its name before the signal stays; one not yet renamed is never half written.
// SIGXFSZ (a write beyond the file size limit, `ulimit -f`) is ignored: the write fails with EFBIG
// ("File too large"), reported by the writer with its file's name, its temporary file removed.
void InstallSignalCleanup();

}  // namespace hysid
