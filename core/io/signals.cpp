#include "core/io/signals.hpp"

#include <limits.h>
#include <signal.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cstring>

namespace hysid {
namespace {

// A slot is free (0), being filled (1) or holds a registered path (2). The handler reads only slots
// in state 2. A slot released and filled again while the handler reads it could give it a mixed
// path; the handler then unlinks a name that does not exist (every temporary name ends in .tmp and
// carries the pid), which is harmless.
struct Slot {
  std::atomic<int> state{0};
  char path[PATH_MAX];
};
static_assert(std::atomic<int>::is_always_lock_free);

std::array<Slot, kMaxTemporaryFiles> g_slots;

struct Ending {
  int signal;
  const char* message;  // written with write(2) before _exit; empty: re-raised with SIG_DFL
};
constexpr std::array<Ending, 4> kEndings{{{SIGINT, "hysid: interrupted by SIGINT\n"},
                                          {SIGTERM, "hysid: interrupted by SIGTERM\n"},
                                          {SIGHUP, "hysid: interrupted by SIGHUP\n"},
                                          {SIGPIPE, ""}}};

extern "C" void OnEndingSignal(int sig) {
  RemoveTemporaryFiles();
  for (const Ending& e : kEndings) {
    if (e.signal != sig || e.message[0] == '\0') continue;
    const ssize_t ignored = ::write(STDERR_FILENO, e.message, std::strlen(e.message));
    (void)ignored;
    ::_exit(128 + sig);
  }
  // SIGPIPE: die of it, as a pipeline tool does (the signal is blocked while its handler runs).
  ::signal(sig, SIG_DFL);
  sigset_t set;
  ::sigemptyset(&set);
  ::sigaddset(&set, sig);
  ::sigprocmask(SIG_UNBLOCK, &set, nullptr);
  ::raise(sig);
  ::_exit(128 + sig);  // not reached
}

}  // namespace

int RegisterTemporaryFile(const std::string& path) {
  if (path.size() >= PATH_MAX) return -1;
  for (int i = 0; i < kMaxTemporaryFiles; ++i) {
    Slot& slot = g_slots[static_cast<std::size_t>(i)];
    int expected = 0;
    if (!slot.state.compare_exchange_strong(expected, 1)) continue;
    std::memcpy(slot.path, path.c_str(), path.size() + 1);
    slot.state.store(2);
    return i;
  }
  return -1;
}

void ReleaseTemporaryFile(int slot) {
  if (slot >= 0 && slot < kMaxTemporaryFiles) g_slots[static_cast<std::size_t>(slot)].state.store(0);
}

void RemoveTemporaryFiles() {
  for (Slot& slot : g_slots) {
    if (slot.state.load() == 2) ::unlink(slot.path);
  }
}

void InstallSignalCleanup() {
  // A write beyond the file size limit (ulimit -f) then fails with EFBIG, which the writer reports
  // naming its file and cleans up after, instead of the process dying silently by SIGXFSZ.
  ::signal(SIGXFSZ, SIG_IGN);
  for (const Ending& e : kEndings) {
    struct sigaction current {};
    if (::sigaction(e.signal, nullptr, &current) != 0 || current.sa_handler == SIG_IGN) continue;
    struct sigaction action {};
    action.sa_handler = OnEndingSignal;
    ::sigemptyset(&action.sa_mask);
    ::sigaction(e.signal, &action, nullptr);
  }
}

}  // namespace hysid
