// Runs a sweep into a run directory (docs/method.md "Sweeps"): shared trajectories, TBB in parallel, every
// finished unit journaled, resumable, shardable; and merges shard directories.
#pragma once

#include <atomic>
#include <filesystem>
#include <string>
#include <vector>

#include "core/model/registry.hpp"
#include "experiments/sweep/config.hpp"
#include "experiments/sweep/plan.hpp"
#include "experiments/sweep/progress.hpp"

namespace hysid {

struct SweepOptions {
  std::filesystem::path out;  // run directory (required)
  int threads = 0;            // 0: all cores
  Shard shard;
  Progress::Mode progress = Progress::Mode::kAuto;
};

struct SweepOutcome {
  long units_total = 0;      // whole sweep
  long units_shard = 0;      // this shard's
  long units_resumed = 0;    // found in the journal
  long units_run = 0;        // run now
  long failures = 0;         // rows whose status is not ok (whole shard)
  long trajectories = 0;     // noise-free simulations run now
  bool interrupted = false;  // `stop` was raised: outputs not written, the journal holds the rows
  double wall_seconds = 0.0;
};

// Throws std::invalid_argument when the run directory holds a different sweep or shard.
// `stop` (may be null) is polled between units: raise it (e.g. from a SIGINT handler) to stop early.
SweepOutcome RunSweep(const SweepConfig& config, const ModelRegistry& registry, const SweepOptions& options,
                      const std::atomic<bool>* stop = nullptr);

// Combines complete shard directories of one sweep into `out` (trials.csv, timings.csv,
// summary.csv, run.json). Throws std::invalid_argument naming the directory when shards belong to
// different sweeps, are incomplete, overlap or leave a shard out.
void MergeShards(const std::vector<std::filesystem::path>& shard_dirs, const std::filesystem::path& out);

}  // namespace hysid
