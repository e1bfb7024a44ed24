// The progress line: counts and percentage in items, "done" or "stopped" at the end.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "experiments/sweep/progress.hpp"
#include "tests/testing/temp_dir.hpp"

namespace {

// Runs `body` with stderr sent to a file; returns what was written.
template <class F>
std::string CaptureStderr(F body) {
  static const auto path = hysid::testing::FreshTempDir("progress") / "stderr.txt";
  std::fflush(stderr);
  const int saved = ::dup(STDERR_FILENO);
  REQUIRE(std::freopen(path.c_str(), "w", stderr) != nullptr);
  body();
  std::fflush(stderr);
  ::dup2(saved, STDERR_FILENO);
  ::close(saved);
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST_CASE("progress: an interrupted run says stopped, with counts and percentage in trials", "[progress]") {
  const std::string out = CaptureStderr([] {
    hysid::Progress p("trials", 4, 0, hysid::Progress::Mode::kLines, /*total_weight=*/1000.0, 0.0, 3600.0);
    p.Tick(900);  // one heavy trial: 90 % of the samples, 25 % of the trials
    p.Tick(10);
  });
  CHECK_THAT(out, Catch::Contains("2/4 trials (50.0 %)"));
  CHECK_THAT(out, Catch::EndsWith("stopped\n"));
  CHECK_THAT(out, !Catch::Contains("ETA"));
}

TEST_CASE("progress: a finished run says done", "[progress]") {
  const std::string out = CaptureStderr([] {
    hysid::Progress p("trials", 2, 1, hysid::Progress::Mode::kLines, 0.0, 0.0, 3600.0);
    p.Tick();
  });
  CHECK_THAT(out, Catch::Contains("2/2 trials (100.0 %)"));
  CHECK_THAT(out, Catch::EndsWith("done\n"));
}

}  // namespace
