// hysid sweep FILE.toml: the Monte Carlo harness; hysid merge: shard directories into one table.
#include <malloc.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "core/io/files.hpp"
#include "core/io/limits.hpp"
#include "core/io/signals.hpp"
#include "experiments/cli/cli.hpp"
#include "experiments/sweep/config.hpp"
#include "experiments/sweep/plan.hpp"
#include "experiments/sweep/runner.hpp"

namespace hysid::cli {
namespace {

// Raised by SIGINT/SIGTERM; the runner stops between units and the journal keeps what finished
// (StopWatchdog ends a unit that takes longer). The exit code is 128 + the signal (130, 143).
std::atomic<bool> g_stop{false};
std::atomic<int> g_stop_signal{SIGINT};
static_assert(std::atomic<bool>::is_always_lock_free && std::atomic<int>::is_always_lock_free);
extern "C" void OnSignal(int sig) {
  g_stop_signal.store(sig);
  g_stop.store(true);
}

// The grace a running unit gets after SIGINT/SIGTERM before the process ends without it.
constexpr auto kStopGrace = std::chrono::milliseconds(500);

// Honours a signal within a second wherever the sweep is: the runner stops between units; a unit
// still running kStopGrace after the signal (a long simulation, identification, refinement or hull)
// is abandoned by ending the process with exit code 128 + the signal. The journal stays valid: every
// row is one write(2) under the journal's lock, and a torn last line is cut off on resume (as after
// SIGKILL), so the same command resumes; the tables are written only after the last unit.
class StopWatchdog {
 public:
  explicit StopWatchdog(std::string out) : out_(std::move(out)), thread_([this] { Watch(); }) {}
  ~StopWatchdog() {
    done_.store(true);
    thread_.join();
  }

 private:
  void Watch() {
    while (!done_.load() && !g_stop.load()) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    const auto deadline = std::chrono::steady_clock::now() + kStopGrace;
    while (!done_.load() && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (done_.load()) return;
    std::fprintf(stderr,
                 "interrupted: the finished trials are in %s/trials.journal (the running ones are left out); "
                 "run the same command again to finish the rest\nhysid: sweep interrupted\n",
                 out_.c_str());
    std::fflush(stdout);
    RemoveTemporaryFiles();  // of the tables, when the signal came while they were written
    std::_Exit(128 + g_stop_signal.load());
  }

  std::string out_;
  std::atomic<bool> done_{false};
  std::thread thread_;  // last: started once the members above exist
};

struct SweepArgs {
  std::string file;
  std::string out;
  int threads = 0;
  std::string shard = "1/1";
  std::string progress = "auto";
  bool dry_run = false;
};

void RunSweepCommand(const SweepArgs& args, const Environment& env) {
  const SweepConfig config = ParseSweepFile(args.file, env.models);
  SweepOptions options;
  options.out = args.out.empty() ? config.out : args.out;
  if (options.out.empty()) BadFlag(fmt::format("--out: not given, and {} has no run.out", args.file));
  if (args.threads < 0) BadFlag(fmt::format("--threads = {}: must be ≥ 1 (0: all cores)", args.threads));
  options.threads = args.threads;
  options.shard = ParseShard(args.shard);
  options.progress = ProgressFlag(args.progress);
  if (!args.dry_run) {
    CheckOutputDirectory("--out", options.out);
  } else if (std::error_code ec;
             std::filesystem::exists(options.out, ec) && !std::filesystem::is_directory(options.out, ec)) {
    BadFlag(fmt::format("--out {}: exists and is not a directory", options.out.string()));
  }
  const std::vector<SweepCell> cells = EnumerateCells(config);
  const long units =
      CheckedProduct(kMaxTrials, static_cast<std::int64_t>(cells.size()), config.trials,
                     fmt::format("{}: {} cells × {} trials", args.file, cells.size(), config.trials));
  std::fprintf(stderr, "%s: %zu cells x %ld trials = %ld trials (shard %s) -> %s\n", args.file.c_str(),
               cells.size(), config.trials, units, options.shard.ToString().c_str(), options.out.c_str());
  if (args.dry_run) return;

  // Each trial allocates and frees a few MB (samples, per-sample decisions). glibc serves blocks that
  // large with mmap/munmap, so every trial would page-fault its memory in again (a sixth of the run
  // time in perf); keeping them in the heap makes freed blocks reusable.
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
  g_stop.store(false);
  // During the run a signal is a stop flag; before and after, the handlers it replaces (main's: remove
  // the temporary files and exit) are in place.
  const auto previous_int = std::signal(SIGINT, OnSignal);
  const auto previous_term = std::signal(SIGTERM, OnSignal);
  const SweepOutcome o = [&] {
    const StopWatchdog watchdog(options.out.string());
    return RunSweep(config, env.models, options, &g_stop);
  }();
  std::signal(SIGINT, previous_int);
  std::signal(SIGTERM, previous_term);
  if (o.interrupted) {
    std::fprintf(stderr,
                 "interrupted: %ld of %ld trials are in %s/trials.journal; run the same command again to "
                 "finish the rest\n",
                 o.units_resumed + o.units_run, o.units_shard, options.out.c_str());
    throw RunFailed("sweep interrupted", 128 + g_stop_signal.load());
  }
  std::printf("%ld trials (%ld resumed, %ld run, %ld failed), %ld trajectories simulated, %.1f s\n",
              o.units_shard, o.units_resumed, o.units_run, o.failures, o.trajectories, o.wall_seconds);
  std::printf("wrote %s/{trials,summary,timings}.csv and run.json\n", options.out.c_str());
}

}  // namespace

void AddSweepCommand(CLI::App& app, Environment& env) {
  auto args = std::make_shared<SweepArgs>();
  CLI::App* cmd = app.add_subcommand(
      "sweep", "run a Monte Carlo sweep file (TOML) in parallel; resumable, shardable (docs/cli.md: Sweeps)");
  cmd->add_option("file", args->file, "sweep file, e.g. experiments/studies/paper_noise.toml")->required();
  cmd->add_option("--out", args->out, "run directory (default: the file's run.out)");
  cmd->add_option("--threads", args->threads, "worker threads (0: all cores); results do not depend on it")
      ->capture_default_str();
  cmd->add_option("--shard", args->shard,
                  "K/N: run only the units with id mod N = K-1 (merge with `hysid merge`)")
      ->capture_default_str();
  cmd->add_option("--progress", args->progress, "auto (bar on a terminal, lines otherwise), bar, lines, none")
      ->capture_default_str();
  cmd->add_flag("--dry-run", args->dry_run, "check the file and print the size of the sweep, run nothing");
  cmd->callback([args, &env] { RunSweepCommand(*args, env); });

  auto dirs = std::make_shared<std::vector<std::string>>();
  auto out = std::make_shared<std::string>();
  CLI::App* merge = app.add_subcommand("merge", "combine the run directories of `hysid sweep --shard K/N`");
  merge->add_option("dirs", *dirs, "the shard run directories")->required();
  merge->add_option("--out", *out, "output directory")->required();
  merge->callback([dirs, out] {
    std::vector<std::filesystem::path> paths(dirs->begin(), dirs->end());
    MergeShards(paths, *out);
    std::printf("merged %zu shards into %s/{trials,summary,timings}.csv\n", paths.size(), out->c_str());
  });
}

}  // namespace hysid::cli
