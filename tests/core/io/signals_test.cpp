// The temporary files a signal removes (core/io/signals.hpp): an AtomicFile's temporary file is
// registered from its creation until it is renamed or removed; the handler's removal, called here
// directly and in a child process ended by each signal, removes exactly the unpublished ones.
#include <catch2/catch.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/io/files.hpp"
#include "core/io/signals.hpp"
#include "tests/testing/temp_dir.hpp"

namespace hysid {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> Entries(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

std::string Text(const fs::path& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST_CASE("only the temporary files not yet published are removed", "[signals]") {
  const fs::path dir = testing::FreshTempDir("signals-remove");
  std::ofstream(dir / "kept.csv") << "old\n";
  AtomicFile published(dir / "published.csv");
  published.Write("new\n");
  published.Close();
  published.Publish();
  AtomicFile open(dir / "kept.csv");
  open.Write("half");
  AtomicFile closed(dir / "closed.csv");
  closed.Close();
  REQUIRE(Entries(dir).size() == 4);  // kept.csv, published.csv and two temporary files
  RemoveTemporaryFiles();
  CHECK(Entries(dir) == std::vector<std::string>{"kept.csv", "published.csv"});
  CHECK(Text(dir / "kept.csv") == "old\n");
  CHECK(Text(dir / "published.csv") == "new\n");
}

TEST_CASE("slots are reused - beyond the last one a file is not registered", "[signals]") {
  std::vector<int> slots;
  for (int i = 0; i < kMaxTemporaryFiles; ++i) {
    slots.push_back(RegisterTemporaryFile("/nonexistent/hysid-signals-test-" + std::to_string(i)));
  }
  const bool all = std::find(slots.begin(), slots.end(), -1) == slots.end();
  CHECK(all);
  CHECK(RegisterTemporaryFile("/nonexistent/one-more") == -1);
  ReleaseTemporaryFile(slots[7]);
  const int again = RegisterTemporaryFile("/nonexistent/again");
  CHECK(again == slots[7]);
  ReleaseTemporaryFile(again);
  slots[7] = -1;
  for (int s : slots) ReleaseTemporaryFile(s);
  CHECK(RegisterTemporaryFile(std::string(5000, 'x')) == -1);  // longer than PATH_MAX
}

// A child with the handlers installed, ended by `sig` while an AtomicFile is open.
int ChildEndedBy(int sig, const fs::path& dir) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(STDERR_FILENO);  // the handler's "hysid: interrupted by ..." goes nowhere
    InstallSignalCleanup();
    AtomicFile file(dir / "out.csv");
    file.Write("partial");
    ::raise(sig);
    ::_exit(0);  // not reached
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return status;
}

TEST_CASE("a signal ends the process with 128 + its number, or by SIGPIPE, and removes the temporary file",
          "[signals]") {
  for (const int sig : {SIGINT, SIGTERM, SIGHUP}) {
    const fs::path dir = testing::FreshTempDir("signals-child-" + std::to_string(sig));
    const int status = ChildEndedBy(sig, dir);
    CHECK(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 128 + sig);
    CHECK(Entries(dir).empty());
  }
  const fs::path dir = testing::FreshTempDir("signals-child-pipe");
  const int status = ChildEndedBy(SIGPIPE, dir);
  CHECK(WIFSIGNALED(status));
  CHECK(WTERMSIG(status) == SIGPIPE);
  CHECK(Entries(dir).empty());
}

}  // namespace
}  // namespace hysid
