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
#include "sim/exogenous.hpp"
#include "sim/simulator.hpp"

namespace hysid {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

nlohmann::json ReadJson(const fs::path& path) {
  const std::string text = ReadWholeFile(path, "run directory's JSON file");  // a directory there is named
  try {
    return nlohmann::json::parse(text);
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

// The files a run directory holds (written by `sweep`; `merge` writes the tables and run.json).
constexpr const char* kRunFiles[] = {"sweep.json",  "trials.journal", "trials.csv",
                                     "summary.csv", "timings.csv",    "run.json"};

// No file the sweep writes may be the sweep file or a model file it reads.
void CheckRunFilesNotInputs(const SweepConfig& config, const fs::path& out) {
  InputFiles inputs;
  inputs.Add("sweep file", config.source);
  for (const SweepModel& m : config.models) inputs.Add(fmt::format("model.file of '{}'", m.name), m.file);
  for (const char* name : kRunFiles) inputs.CheckNotInput("--out", out / name);
}

// Claims the run directory for this sweep and shard: writes sweep.json, or checks that the one there
// names this sweep and shard (a different sweep or shard is refused, not mixed in).
void ClaimDirectory(const SweepConfig& config, const SweepOptions& options, long units_total,
                    std::size_t n_cells) {
  const nlohmann::json identity = {
      {"hysid_sweep", 1},           {"hash", config.Hash()}, {"shard", options.shard.ToString()},
      {"units_total", units_total}, {"cells", n_cells},      {"source", config.source},
      {"config", config.ToJson()}};
  const fs::path identity_path = options.out / "sweep.json";
  if (!fs::exists(identity_path)) {
    // Tables without a sweep.json or a journal are another run's (a merge's): never overwritten.
    for (const char* name : kRunFiles) {
      if (!fs::exists(options.out / "trials.journal") && fs::exists(options.out / name)) {
        throw std::invalid_argument(fmt::format(
            "{}: holds another study ({} without sweep.json or trials.journal, e.g. the output of "
            "`hysid merge`); use another --out",
            options.out.string(), name));
      }
    }
    WriteJson(identity_path, identity);
    return;
  }
  const nlohmann::json old = ReadJson(identity_path);
  if (old.value("hash", "") != identity["hash"]) {
    const std::string what = DescribeConfigChange(old.value("config", nlohmann::json::object()), config);
    throw std::invalid_argument(fmt::format(
        "{}: holds another study (sweep hash {} there, {} now; {} differs: the sweep file or a model file it "
        "names changed since that run); use another --out or delete the directory",
        options.out.string(), old.value("hash", "?"), config.Hash(), what.empty() ? "its identity" : what));
  }
  if (old.value("shard", "") != identity["shard"]) {
    throw std::invalid_argument(fmt::format("{}: holds shard {}, not shard {}", options.out.string(),
                                            old.value("shard", "?"), options.shard.ToString()));
  }
}

// The shard's units that the journal does not hold yet; counts the shard's and the resumed units.
std::vector<long> PendingUnits(const Journal& journal, const Shard& shard, SweepOutcome* outcome) {
  std::vector<long> todo;
  for (long id = 0; id < outcome->units_total; ++id) {
    if (!shard.Contains(id)) continue;
    ++outcome->units_shard;
    if (journal.recovered().count(id)) {
      ++outcome->units_resumed;
    } else {
      todo.push_back(id);
    }
  }
  return todo;
}

// What the units of one trajectory group share: x0, the noise-free trajectory (or the simulator's
// refusal) and, with grid.refine, the CRLB at σ = 1.
struct GroupTruth {
  Vec x0;
  InputSignal inputs;  // a model with inputs: its defaults at the samples
  Trajectory truth;
  std::string sim_error;
  Crlb crlb;
};

// Runs the pending units of a shard in parallel and appends each row to the journal.
class UnitRunner {
 public:
  UnitRunner(const SweepConfig& config, const std::vector<Model>& models, const std::vector<SweepCell>& cells,
             Journal* journal, const std::atomic<bool>* stop)
      : config_(config), models_(models), cells_(cells), journal_(journal), stop_(stop) {}

  // The ETA weight of a unit: a trial costs about its number of samples.
  long SamplesOf(long id) const {
    const SweepCell& cell = CellOf(id);
    return static_cast<long>(config_.models[static_cast<std::size_t>(cell.model)].t_end / cell.dt) + 1;
  }

  // One task per (group, trial): the trial's standard normals are drawn once and shared by the
  // group's units of that trial (common random numbers); a task never waits, so each thread holds
  // at most one task's normals, and `isolate` keeps a thread waiting for its group's tasks from
  // starting another group (one trajectory per thread).
  void Run(const std::vector<TrajectoryGroup>& groups, Progress* progress) {
    tbb::parallel_for(std::size_t{0}, groups.size(), [&](std::size_t gi) {
      if (Stopped()) return;
      const TrajectoryGroup& g = groups[gi];
      const GroupTruth truth = SimulateGroup(g);
      const std::vector<std::vector<long>> by_trial = UnitsByTrial(g, config_.trials);
      tbb::this_task_arena::isolate([&] {
        tbb::parallel_for(std::size_t{0}, by_trial.size(),
                          [&](std::size_t ti) { RunTrialUnits(g, truth, by_trial[ti], progress); });
      });
    });
  }

  long units_run() const { return run_.load(); }
  long trajectories() const { return trajectories_.load(); }

 private:
  const SweepCell& CellOf(long id) const {
    return cells_[static_cast<std::size_t>(UnitOf(id, config_.trials).cell)];
  }
  bool Stopped() const { return stop_ != nullptr && stop_->load(std::memory_order_relaxed); }

  GroupTruth SimulateGroup(const TrajectoryGroup& g) {
    const SweepModel& sm = config_.models[static_cast<std::size_t>(g.model)];
    const Model& model = models_[static_cast<std::size_t>(g.model)];
    GroupTruth out;
    out.x0 = InitialState(config_, g.model, g.x0_trial < 0 ? 0 : g.x0_trial);
    try {
      out.inputs = DefaultInputs(model, g.dt, sm.t_end);
      Exogenous exo;
      if (!out.inputs.empty()) exo.inputs = &out.inputs;
      out.truth = Simulate(model, out.x0, SampleGrid{sm.t_end, g.dt}, config_.simulator, exo);
    } catch (const std::invalid_argument& e) {
      out.sim_error = e.what();
    }
    trajectories_.fetch_add(1, std::memory_order_relaxed);
    out.crlb.status = CrlbStatus::kSimulationFailed;
    if (config_.grid.refine_axis && out.sim_error.empty() && out.truth.status.completed()) {
      out.crlb = UnitCrlb(model, out.x0, g.dt, sm.t_end, &out.inputs);
    }
    return out;
  }

  // The units `ids` of one trial of group `g`, in order, on the trial's shared noise.
  void RunTrialUnits(const TrajectoryGroup& g, const GroupTruth& truth, const std::vector<long>& ids,
                     Progress* progress) {
    const long trial = UnitOf(ids.front(), config_.trials).trial;
    Mat normals;
    NoisySamples noisy;
    const bool noisy_units =
        std::any_of(ids.begin(), ids.end(), [&](long id) { return CellOf(id).sigma > 0; });
    if (noisy_units && truth.sim_error.empty() && truth.truth.status.completed() && !Stopped()) {
      normals.resize(truth.truth.x.rows(), truth.truth.x.cols());
      FillStandardNormals(TrialNoiseKey(config_, g.model, g.dt, trial), 0, normals.data(),
                          static_cast<std::size_t>(normals.size()));
    }
    const TrialInputs in{&truth.x0,
                         &truth.truth,
                         &normals,
                         &noisy,
                         truth.sim_error,
                         config_.grid.refine_axis ? &truth.crlb : nullptr,
                         truth.inputs.empty() ? nullptr : &truth.inputs,
                         stop_};
    // Consecutive units of one σ (the same noisy samples) are run together (RunTrials); each row's
    // time is its share of theirs.
    for (std::size_t a = 0; a < ids.size();) {
      if (Stopped()) return;
      std::vector<const SweepCell*> cells{&CellOf(ids[a])};
      std::size_t b = a + 1;
      for (; b < ids.size() && CellOf(ids[b]).sigma == cells.front()->sigma; ++b) cells.push_back(&CellOf(ids[b]));
      const std::vector<long> units(ids.begin() + static_cast<std::ptrdiff_t>(a),
                                    ids.begin() + static_cast<std::ptrdiff_t>(b));
      const auto start = Clock::now();
      std::vector<std::vector<std::string>> rows = RunTrials(config_, models_, cells, units, trial, in);
      if (Stopped()) return;  // a refinement may have ended early: not journaled, run again on resume
      const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count() /
                        static_cast<double>(units.size());
      for (std::size_t i = 0; i < units.size(); ++i) {
        rows[i].push_back(fmt::format("{:.3f}", ms));
        journal_->Append(rows[i]);
        run_.fetch_add(1, std::memory_order_relaxed);
        progress->Tick(SamplesOf(units[i]));
      }
      a = b;
    }
  }

  const SweepConfig& config_;
  const std::vector<Model>& models_;
  const std::vector<SweepCell>& cells_;
  Journal* journal_;
  const std::atomic<bool>* stop_;
  std::atomic<long> run_{0}, trajectories_{0};
};

int ThreadCount(const SweepOptions& options) {
  return options.threads > 0 ? options.threads : tbb::info::default_concurrency();
}

// Runs the shard's units that the journal does not hold yet (all of them in a fresh directory).
void RunPendingUnits(const SweepConfig& config, const std::vector<Model>& models,
                     const std::vector<SweepCell>& cells, const std::vector<std::string>& header,
                     const SweepOptions& options, const std::atomic<bool>* stop, SweepOutcome* outcome) {
  Journal journal(options.out / "trials.journal", JournalHeader(header), config.Hash(),
                  options.shard.ToString());
  CheckRecovered(journal, config, cells, options.shard, outcome->units_total);
  const std::vector<long> todo = PendingUnits(journal, options.shard, outcome);
  const std::vector<TrajectoryGroup> groups = GroupUnits(config, cells, todo);
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(ThreadCount(options)));
  UnitRunner runner(config, models, cells, &journal, stop);
  {
    double total_weight = 0, done_weight = 0;
    for (long id = 0; id < outcome->units_total; ++id) {
      if (!options.shard.Contains(id)) continue;
      total_weight += static_cast<double>(runner.SamplesOf(id));
      if (journal.recovered().count(id)) done_weight += static_cast<double>(runner.SamplesOf(id));
    }
    Progress progress("trials", outcome->units_shard, outcome->units_resumed, options.progress, total_weight,
                      done_weight);
    runner.Run(groups, &progress);
  }
  outcome->units_run = runner.units_run();
  outcome->trajectories = runner.trajectories();
}

// Every unit of the shard is in the journal: writes trials.csv, timings.csv and summary.csv from it
// (the summary's cells on the sweep's threads) and counts the failures.
void WriteShardTables(const SweepConfig& config, const std::vector<SweepCell>& cells,
                      const std::vector<std::string>& header, const SweepOptions& options,
                      SweepOutcome* outcome) {
  const Journal journal(options.out / "trials.journal", JournalHeader(header), config.Hash(),
                        options.shard.ToString());
  CheckRecovered(journal, config, cells, options.shard, outcome->units_total);
  std::map<long, std::vector<std::string>> rows;
  const long status_col = std::find(header.begin(), header.end(), "status") - header.begin();
  for (const auto& [id, cells_of_row] : journal.recovered()) {
    if (!options.shard.Contains(id) || id >= outcome->units_total) continue;
    if (cells_of_row[static_cast<std::size_t>(status_col)] != kTrialOk) ++outcome->failures;
    rows.emplace(id, cells_of_row);
  }
  // The summary's cells in parallel on the sweep's threads.
  const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                  static_cast<std::size_t>(ThreadCount(options)));
  WriteSweepTables(options.out, header, rows, config.baseline);
}

// The resolved models of the sweep: every parameter value, x0 (or its range), δt grid and horizon
// actually simulated.
nlohmann::json ResolvedModels(const SweepConfig& config, const std::vector<Model>& models) {
  nlohmann::json out = nlohmann::json::array();
  for (std::size_t i = 0; i < models.size(); ++i) {
    const SweepModel& sm = config.models[i];
    nlohmann::json m = ResolvedModelJson(models[i], sm.x0, config.grid.dt, sm.t_end);
    if (!sm.x0_range.empty()) {
      m.erase("x0");
      m["x0_range"] = sm.x0_range;
    }
    out.push_back(std::move(m));
  }
  return out;
}

nlohmann::json SweepRunJson(const SweepConfig& config, const std::vector<Model>& models,
                            const SweepOptions& options, const SweepOutcome& outcome) {
  return {{"command", "hysid sweep"},
          {"source", config.source},
          {"hash", config.Hash()},
          {"master_seed", config.seed},
          {"config", config.ToJson()},
          {"models", ResolvedModels(config, models)},
          {"shard", options.shard.ToString()},
          {"threads", ThreadCount(options)},
          {"units_total", outcome.units_total},
          {"units_shard", outcome.units_shard},
          {"units_resumed", outcome.units_resumed},
          {"units_run", outcome.units_run},
          {"failures", outcome.failures},
          {"trajectories_simulated", outcome.trajectories},
          {"wall_seconds", outcome.wall_seconds},
          {"wall_seconds_note", "this invocation only (a resumed run's earlier part is not included)"},
          {"context", BuildContext()}};
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
  CheckOutputDirectory("--out", options.out);
  CheckRunFilesNotInputs(config, options.out);
  const DirectoryLock lock(options.out);
  ClaimDirectory(config, options, outcome.units_total, cells.size());
  RunPendingUnits(config, models, cells, header, options, stop, &outcome);
  outcome.wall_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  if (outcome.units_resumed + outcome.units_run < outcome.units_shard) {
    outcome.interrupted = true;
    return outcome;
  }
  WriteShardTables(config, cells, header, options, &outcome);
  WriteJson(options.out / "run.json", SweepRunJson(config, models, options, outcome));
  return outcome;
}

namespace {

// The shard directories must not include the output directory.
void CheckMergeOutput(const std::vector<fs::path>& dirs, const fs::path& out) {
  if (dirs.empty()) throw std::invalid_argument("hysid merge: give the shard directories");
  for (const fs::path& dir : dirs) {
    std::error_code ec;
    if (fs::exists(out, ec) && fs::equivalent(dir, out, ec)) {
      throw std::invalid_argument(fmt::format(
          "--out {}: is one of the shard directories being merged ({}); give another output directory",
          out.string(), dir.string()));
    }
  }
}

// The output directory of `merge` holds no run files, or an earlier merge of the same sweep (which is
// replaced); a sweep's run directory or another study's merge is refused, not overwritten.
void CheckMergeTarget(const fs::path& out, const std::string& hash) {
  std::error_code ec;
  const auto refuse = [&](const std::string& what) {
    throw std::invalid_argument(fmt::format(
        "--out {}: {}; merge writes its tables only into a new directory or over an earlier merge of the "
        "same sweep: give another --out",
        out.string(), what));
  };
  if (fs::exists(out / "sweep.json", ec) || fs::exists(out / "trials.journal", ec)) {
    refuse("is the run directory of a sweep (it holds sweep.json or trials.journal)");
  }
  if (fs::exists(out / "run.json", ec)) {
    nlohmann::json old = ReadJson(out / "run.json");
    if (!old.is_object()) old = nlohmann::json::object();
    if (old.value("command", "") != "hysid merge" || old.value("hash", "") != hash) {
      refuse(fmt::format("holds another study (run.json: {}, hash {}; these shards are sweep {})",
                         old.value("command", "?"), old.value("hash", "?"), hash));
    }
    return;
  }
  for (const char* name : kRunFiles) {
    if (fs::exists(out / name, ec)) refuse(fmt::format("holds {} of an unknown study (no run.json)", name));
  }
}

// One complete shard directory: its identity and its rows, each with its wall_ms as the last cell.
struct ShardTables {
  nlohmann::json identity;
  Shard shard;
  std::vector<std::string> header;
  std::map<long, std::vector<std::string>> rows;
};

ShardTables ReadShardTables(const fs::path& dir) {
  const fs::path idp = dir / "sweep.json";
  if (!fs::exists(idp)) {
    throw std::invalid_argument(fmt::format("{}: not a sweep run directory (no sweep.json)", dir.string()));
  }
  ShardTables s;
  s.identity = ReadJson(idp);
  s.shard = ParseShard(s.identity.value("shard", ""));
  if (!fs::exists(dir / "trials.csv")) {
    throw std::invalid_argument(
        fmt::format("{}: shard {} is not complete (no trials.csv); run its command again to finish it",
                    dir.string(), s.shard.ToString()));
  }
  ReadTrialsCsv(dir / "trials.csv", &s.header, &s.rows);
  std::vector<std::string> th;
  std::map<long, std::vector<std::string>> timing;
  ReadTrialsCsv(dir / "timings.csv", &th, &timing);
  for (auto& [unit, cells] : s.rows) {
    if (!s.shard.Contains(unit)) {
      throw std::invalid_argument(
          fmt::format("{}: unit {} does not belong to shard {}", dir.string(), unit, s.shard.ToString()));
    }
    const auto t = timing.find(unit);
    cells.push_back(t == timing.end() ? std::string() : t->second.back());
  }
  return s;
}

// `s` must be another shard of the same sweep as `first`, split the same way, with the same columns.
void CheckSameSweep(const fs::path& dir, const ShardTables& s, const ShardTables& first) {
  const std::string hash = first.identity.value("hash", "");
  if (s.identity.value("hash", "") != hash) {
    throw std::invalid_argument(fmt::format("{}: a different sweep (hash {}, the first shard has {})",
                                            dir.string(), s.identity.value("hash", "?"), hash));
  }
  if (s.shard.n != first.shard.n) {
    throw std::invalid_argument(fmt::format("{}: shard {} does not split into {} like the first",
                                            dir.string(), s.shard.ToString(), first.shard.n));
  }
  if (s.header != first.header)
    throw std::invalid_argument(fmt::format("{}: trials.csv has other columns", dir.string()));
}

}  // namespace

void MergeShards(const std::vector<fs::path>& dirs, const fs::path& out) {
  CheckMergeOutput(dirs, out);
  ShardTables first;
  std::set<long> seen_k;
  std::map<long, std::vector<std::string>> rows;
  for (const fs::path& dir : dirs) {
    ShardTables s = ReadShardTables(dir);
    if (seen_k.empty()) first = s;
    CheckSameSweep(dir, s, first);
    if (!seen_k.insert(s.shard.k).second) {
      throw std::invalid_argument(fmt::format("{}: shard {} given twice", dir.string(), s.shard.ToString()));
    }
    rows.merge(s.rows);
  }
  for (long k = 1; k <= first.shard.n; ++k) {
    if (!seen_k.count(k))
      throw std::invalid_argument(fmt::format("hysid merge: shard {}/{} is missing", k, first.shard.n));
  }
  const long total = first.identity.value("units_total", -1L);
  if (static_cast<long>(rows.size()) != total) {
    throw std::invalid_argument(
        fmt::format("hysid merge: {} units in the shards, the sweep has {}", rows.size(), total));
  }
  // The inputs are read and checked before the output directory is made or locked.
  CheckOutputDirectory("--out", out);
  const DirectoryLock lock(out);
  CheckMergeTarget(out, first.identity.value("hash", ""));
  const nlohmann::json config = first.identity.value("config", nlohmann::json{});
  WriteSweepTables(out, first.header, rows, BaselineFromJson(config));
  std::vector<std::string> names;
  for (const auto& d : dirs) names.push_back(d.string());
  WriteJson(out / "run.json", {{"command", "hysid merge"},
                               {"hash", first.identity.value("hash", "")},
                               {"config", config},
                               {"shards", names},
                               {"units_total", total},
                               {"context", BuildContext()}});
}

}  // namespace hysid
