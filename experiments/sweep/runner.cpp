#include "experiments/sweep/runner.hpp"

#include <algorithm>
#include <chrono>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>
#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/info.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include "core/io/files.hpp"
#include "core/io/limits.hpp"
#include "experiments/sweep/journal.hpp"
#include "experiments/sweep/run_context.hpp"
#include "experiments/sweep/tables.hpp"
#include "experiments/sweep/trial.hpp"
#include "sim/simulator.hpp"

namespace hysid {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

nlohmann::json ReadJson(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(fmt::format("{}: cannot open", path.string()));
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(fmt::format("{}: not valid JSON: {}", path.string(), e.what()));
  }
}

void WriteJson(const fs::path& path, const nlohmann::json& j) { WriteFileAtomically(path, j.dump(2) + "\n"); }

// A recovered row must be the unit it claims: in range, in the shard, and with the cell, trial and
// cell keys (model, δt, σ, r, false_alarm, estimator, detector) the plan gives that id.
void CheckRecovered(const Journal& journal, const SweepConfig& config, const std::vector<SweepCell>& cells,
                    const Shard& shard, long units_total) {
  for (const auto& entry : journal.recovered()) {
    const long id = entry.first;
    const std::vector<std::string>& row = entry.second;
    const auto fail = [&](const std::string& what) {
      throw std::invalid_argument(
          fmt::format("{}:{}: the row of unit {} {}; the journal is not this sweep's: "
                      "delete the directory or use another --out",
                      journal.path().string(), journal.line_of(id), id, what));
    };
    if (id >= units_total) fail(fmt::format("is beyond the sweep's {} units", units_total));
    if (!shard.Contains(id)) fail(fmt::format("is not in shard {}", shard.ToString()));
    const UnitId u = UnitOf(id, config.trials);
    const SweepCell& c = cells[static_cast<std::size_t>(u.cell)];
    // The key columns of trials.csv (trial.cpp): unit, cell, trial, model, dt, sigma, the option axes,
    // estimator, detector and, with grid.refine, refine.
    std::vector<std::string> expected{
        fmt::format("{}", id),      fmt::format("{}", u.cell),
        fmt::format("{}", u.trial), config.models[static_cast<std::size_t>(c.model)].name,
        FormatNumber(c.dt),         FormatNumber(c.sigma)};
    for (double v : c.options) expected.push_back(FormatNumber(v));
    expected.emplace_back(ToString(c.estimator));
    expected.emplace_back(config.oracle ? std::string("oracle") : std::string(ToString(c.detector)));
    if (config.grid.refine_axis) expected.push_back(c.refine);
    for (std::size_t i = 0; i < expected.size(); ++i) {
      if (row[i] != expected[i]) {
        fail(
            fmt::format("has {} in column {}, the plan has {}", Abbreviated(row[i], 40), i + 1, expected[i]));
      }
    }
  }
}

// Every cell must have at most one baseline cell (else summary.csv could not pair it).
void CheckBaseline(const SweepConfig& config, const std::vector<SweepCell>& cells) {
  if (config.baseline.empty()) return;
  std::vector<std::vector<std::string>> keys;
  for (const SweepCell& c : cells) {
    std::vector<std::string> k{config.models[static_cast<std::size_t>(c.model)].name, FormatNumber(c.dt),
                               FormatNumber(c.sigma)};
    for (double v : c.options) k.push_back(FormatNumber(v));
    k.emplace_back(ToString(c.estimator));
    k.emplace_back(ToString(c.detector));
    k.emplace_back(config.grid.refine_axis ? c.refine : std::string());
    keys.push_back(std::move(k));
  }
  const std::vector<long> base = MatchBaselines(BaselineKeyNames(), keys, config.baseline);
  for (std::size_t i = 0; i < base.size(); ++i) {
    if (base[i] != -2) continue;
    std::vector<std::string> named;
    for (const auto& [k, v] : config.baseline) named.push_back(fmt::format("{} = {}", k, v));
    throw std::invalid_argument(fmt::format(
        "{}: summary.baseline {{{}}}: cell {} ({}) matches several cells; name the keys that tell them apart",
        config.source, fmt::join(named, ", "), i, fmt::join(keys[i], ", ")));
  }
}

Baseline BaselineFromJson(const nlohmann::json& config) {
  Baseline b;
  if (config.contains("summary") && config["summary"].contains("baseline")) {
    for (const auto& [k, v] : config["summary"]["baseline"].items()) b.emplace_back(k, v.get<std::string>());
  }
  return b;
}

}  // namespace

SweepOutcome RunSweep(const SweepConfig& config, const ModelRegistry& registry, const SweepOptions& options,
                      const std::atomic<bool>* stop) {
  const auto t0 = Clock::now();
  if (options.out.empty()) throw std::invalid_argument("no output directory: give --out or run.out");
  if (options.threads < 0)
    throw std::invalid_argument(fmt::format("--threads = {}: must be ≥ 1", options.threads));
  std::vector<Model> models;
  for (const SweepModel& m : config.models) models.push_back(m.Build(registry));
  const std::vector<SweepCell> cells = EnumerateCells(config);
  const std::vector<std::string> header = TrialHeader(config, models);
  CheckBaseline(config, cells);
  SweepOutcome outcome;
  outcome.units_total =
      CheckedProduct(kMaxTrials, static_cast<std::int64_t>(cells.size()), config.trials,
                     fmt::format("{}: {} cells × {} trials", config.source, cells.size(), config.trials));

  // The directory's identity: a different sweep or shard is refused, not mixed in.
  CheckOutputDirectory("--out", options.out);
  const DirectoryLock lock(options.out);
  const nlohmann::json identity = {{"hysid_sweep", 1},
                                   {"hash", config.Hash()},
                                   {"shard", options.shard.ToString()},
                                   {"units_total", outcome.units_total},
                                   {"cells", cells.size()},
                                   {"source", config.source},
                                   {"config", config.ToJson()}};
  const fs::path identity_path = options.out / "sweep.json";
  if (fs::exists(identity_path)) {
    const nlohmann::json old = ReadJson(identity_path);
    if (old.value("hash", "") != identity["hash"]) {
      throw std::invalid_argument(fmt::format(
          "{}: holds the results of a different sweep configuration (hash {} here, {} now); use another "
          "--out or delete the directory",
          options.out.string(), old.value("hash", "?"), config.Hash()));
    }
    if (old.value("shard", "") != identity["shard"]) {
      throw std::invalid_argument(fmt::format("{}: holds shard {}, not shard {}", options.out.string(),
                                              old.value("shard", "?"), options.shard.ToString()));
    }
  } else {
    WriteJson(identity_path, identity);
  }

  std::vector<long> todo;
  {
    Journal journal(options.out / "trials.journal", JournalHeader(header), config.Hash(),
                    options.shard.ToString());
    CheckRecovered(journal, config, cells, options.shard, outcome.units_total);
    for (long id = 0; id < outcome.units_total; ++id) {
      if (!options.shard.Contains(id)) continue;
      ++outcome.units_shard;
      if (journal.recovered().count(id)) {
        ++outcome.units_resumed;
      } else {
        todo.push_back(id);
      }
    }
    const std::vector<TrajectoryGroup> groups = GroupUnits(config, cells, todo);
    const int threads = options.threads > 0 ? options.threads : tbb::info::default_concurrency();
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                              static_cast<std::size_t>(threads));
    std::atomic<long> run{0}, trajectories{0};
    const auto stopped = [stop] { return stop && stop->load(std::memory_order_relaxed); };
    {
      // Weights for the ETA: a trial costs about its number of samples.
      const auto samples_of = [&](long id) {
        const SweepCell& cell = cells[static_cast<std::size_t>(UnitOf(id, config.trials).cell)];
        return static_cast<long>(config.models[static_cast<std::size_t>(cell.model)].t_end / cell.dt) + 1;
      };
      double total_weight = 0, done_weight = 0;
      for (long id = 0; id < outcome.units_total; ++id) {
        if (!options.shard.Contains(id)) continue;
        total_weight += static_cast<double>(samples_of(id));
        if (journal.recovered().count(id)) done_weight += static_cast<double>(samples_of(id));
      }
      Progress progress("trials", outcome.units_shard, outcome.units_resumed, options.progress, total_weight,
                        done_weight);
      // One task per (group, trial): the trial's standard normals are drawn once and shared by the
      // group's units of that trial (common random numbers); a task never waits, so each thread holds
      // at most one task's normals, and `isolate` keeps a thread waiting for its group's tasks from
      // starting another group (one trajectory per thread).
      tbb::parallel_for(std::size_t{0}, groups.size(), [&](std::size_t gi) {
        if (stopped()) return;
        const TrajectoryGroup& g = groups[gi];
        const SweepModel& sm = config.models[static_cast<std::size_t>(g.model)];
        const Vec x0 = InitialState(config, g.model, g.x0_trial < 0 ? 0 : g.x0_trial);
        Trajectory truth;
        std::string sim_error;
        try {
          truth = Simulate(models[static_cast<std::size_t>(g.model)], x0, SampleGrid{sm.t_end, g.dt},
                           config.simulator);
        } catch (const std::invalid_argument& e) {
          sim_error = e.what();
        }
        trajectories.fetch_add(1, std::memory_order_relaxed);
        Crlb crlb;
        crlb.status = CrlbStatus::kSimulationFailed;
        if (config.grid.refine_axis && sim_error.empty() && truth.status.completed()) {
          crlb = UnitCrlb(models[static_cast<std::size_t>(g.model)], x0, g.dt, sm.t_end);
        }
        const std::vector<std::vector<long>> by_trial = UnitsByTrial(g, config.trials);
        tbb::this_task_arena::isolate([&] {
          tbb::parallel_for(std::size_t{0}, by_trial.size(), [&](std::size_t ti) {
            const std::vector<long>& ids = by_trial[ti];
            const long trial = UnitOf(ids.front(), config.trials).trial;
            Mat normals, noisy;
            const bool noisy_units = std::any_of(ids.begin(), ids.end(), [&](long id) {
              return cells[static_cast<std::size_t>(UnitOf(id, config.trials).cell)].sigma > 0;
            });
            if (noisy_units && sim_error.empty() && truth.status.completed() && !stopped()) {
              normals.resize(truth.x.rows(), truth.x.cols());
              FillStandardNormals(TrialNoiseKey(config, g.model, g.dt, trial), 0, normals.data(),
                                  static_cast<std::size_t>(normals.size()));
            }
            const TrialInputs in{&x0,    &truth,    &normals,
                                 &noisy, sim_error, config.grid.refine_axis ? &crlb : nullptr};
            for (const long id : ids) {
              if (stopped()) return;
              const auto start = Clock::now();
              std::vector<std::string> row =
                  RunTrial(config, models, cells[static_cast<std::size_t>(UnitOf(id, config.trials).cell)],
                           id, trial, in);
              row.push_back(fmt::format(
                  "{:.3f}", std::chrono::duration<double, std::milli>(Clock::now() - start).count()));
              journal.Append(row);
              run.fetch_add(1, std::memory_order_relaxed);
              progress.Tick(samples_of(id));
            }
          });
        });
      });
    }
    outcome.units_run = run.load();
    outcome.trajectories = trajectories.load();
  }
  outcome.wall_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  if (outcome.units_resumed + outcome.units_run < outcome.units_shard) {
    outcome.interrupted = true;
    return outcome;
  }

  // Every unit of the shard is in the journal: write the tables from it.
  const Journal journal(options.out / "trials.journal", JournalHeader(header), config.Hash(),
                        options.shard.ToString());
  CheckRecovered(journal, config, cells, options.shard, outcome.units_total);
  std::map<long, std::vector<std::string>> rows;
  const long status_col = std::find(header.begin(), header.end(), "status") - header.begin();
  for (const auto& [id, cells_of_row] : journal.recovered()) {
    if (!options.shard.Contains(id) || id >= outcome.units_total) continue;
    if (cells_of_row[static_cast<std::size_t>(status_col)] != kTrialOk) ++outcome.failures;
    rows.emplace(id, cells_of_row);
  }
  WriteSweepTables(options.out, header, rows, config.baseline);
  WriteJson(options.out / "run.json",
            {{"command", "hysid sweep"},
             {"source", config.source},
             {"hash", config.Hash()},
             {"master_seed", config.seed},
             {"config", config.ToJson()},
             {"shard", options.shard.ToString()},
             {"threads", options.threads > 0 ? options.threads : tbb::info::default_concurrency()},
             {"units_total", outcome.units_total},
             {"units_shard", outcome.units_shard},
             {"units_resumed", outcome.units_resumed},
             {"units_run", outcome.units_run},
             {"failures", outcome.failures},
             {"trajectories_simulated", outcome.trajectories},
             {"wall_seconds", outcome.wall_seconds},
             {"wall_seconds_note", "this invocation only (a resumed run's earlier part is not included)"},
             {"context", BuildContext()}});
  return outcome;
}

void MergeShards(const std::vector<fs::path>& dirs, const fs::path& out) {
  if (dirs.empty()) throw std::invalid_argument("hysid merge: give the shard directories");
  for (const fs::path& dir : dirs) {
    std::error_code ec;
    if (fs::exists(out, ec) && fs::equivalent(dir, out, ec)) {
      throw std::invalid_argument(fmt::format(
          "--out {}: is one of the shard directories being merged ({}); give another output directory",
          out.string(), dir.string()));
    }
  }
  CheckOutputDirectory("--out", out);
  const DirectoryLock lock(out);
  std::string hash;
  long n_shards = -1, total = -1;
  std::set<long> seen_k;
  std::vector<std::string> header;
  nlohmann::json config;
  std::map<long, std::vector<std::string>> rows;
  for (const fs::path& dir : dirs) {
    const fs::path idp = dir / "sweep.json";
    if (!fs::exists(idp)) {
      throw std::invalid_argument(fmt::format("{}: not a sweep run directory (no sweep.json)", dir.string()));
    }
    const nlohmann::json id = ReadJson(idp);
    const Shard shard = ParseShard(id.value("shard", ""));
    if (hash.empty()) {
      hash = id.value("hash", "");
      n_shards = shard.n;
      total = id.value("units_total", -1L);
      config = id.value("config", nlohmann::json{});
    } else if (id.value("hash", "") != hash) {
      throw std::invalid_argument(fmt::format("{}: a different sweep (hash {}, the first shard has {})",
                                              dir.string(), id.value("hash", "?"), hash));
    } else if (shard.n != n_shards) {
      throw std::invalid_argument(fmt::format("{}: shard {} does not split into {} like the first",
                                              dir.string(), shard.ToString(), n_shards));
    }
    if (!seen_k.insert(shard.k).second) {
      throw std::invalid_argument(fmt::format("{}: shard {} given twice", dir.string(), shard.ToString()));
    }
    if (!fs::exists(dir / "trials.csv")) {
      throw std::invalid_argument(
          fmt::format("{}: shard {} is not complete (no trials.csv); run its command again to finish it",
                      dir.string(), shard.ToString()));
    }
    std::vector<std::string> h;
    std::map<long, std::vector<std::string>> r;
    ReadTrialsCsv(dir / "trials.csv", &h, &r);
    std::vector<std::string> th;
    std::map<long, std::vector<std::string>> timing;
    ReadTrialsCsv(dir / "timings.csv", &th, &timing);
    if (header.empty()) header = h;
    if (h != header)
      throw std::invalid_argument(fmt::format("{}: trials.csv has other columns", dir.string()));
    for (auto& [unit, cells] : r) {
      if (!shard.Contains(unit)) {
        throw std::invalid_argument(
            fmt::format("{}: unit {} does not belong to shard {}", dir.string(), unit, shard.ToString()));
      }
      const auto t = timing.find(unit);
      cells.push_back(t == timing.end() ? std::string() : t->second.back());
      rows.emplace(unit, std::move(cells));
    }
  }
  for (long k = 1; k <= n_shards; ++k) {
    if (!seen_k.count(k))
      throw std::invalid_argument(fmt::format("hysid merge: shard {}/{} is missing", k, n_shards));
  }
  if (static_cast<long>(rows.size()) != total) {
    throw std::invalid_argument(
        fmt::format("hysid merge: {} units in the shards, the sweep has {}", rows.size(), total));
  }
  fs::create_directories(out);
  WriteSweepTables(out, header, rows, BaselineFromJson(config));
  std::vector<std::string> names;
  for (const auto& d : dirs) names.push_back(d.string());
  WriteJson(out / "run.json", {{"command", "hysid merge"},
                               {"hash", hash},
                               {"config", config},
                               {"shards", names},
                               {"units_total", total},
                               {"context", BuildContext()}});
}

}  // namespace hysid
