// The sweep harness: file errors, cells, determinism across thread counts, resume after a kill,
// shards merged, failed trials as rows, summary statistics against closed forms, common random
// numbers and paired differences against a baseline cell.
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <tuple>

#include <catch2/catch.hpp>
#include <fmt/format.h>

#include "core/builtin/builtin.hpp"
#include "core/identify/identifier.hpp"
#include "core/model/registry.hpp"
#include "experiments/sweep/config.hpp"
#include "experiments/sweep/journal.hpp"
#include "experiments/sweep/plan.hpp"
#include "experiments/sweep/runner.hpp"
#include "experiments/sweep/tables.hpp"
#include "experiments/sweep/trial.hpp"
#include "sim/measurement.hpp"
#include "sim/simulator.hpp"
#include "tests/testing/temp_dir.hpp"

namespace fs = std::filesystem;
using namespace hysid;

namespace {

ModelRegistry Registry() {
  ModelRegistry r;
  RegisterBuiltinModels(r);
  return r;
}

// A fresh directory for one test case.
fs::path TempDir(const std::string& name) { return testing::FreshTempDir("sweep-" + name); }

std::string Slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  REQUIRE(in);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Small but not trivial: 2 δt × 2 σ × (2 r paper + residual) = 12 cells × 4 trials, 4 s of impact-msd
// from drawn initial states.
const char* kSweep = R"(
[model]
name = "impact-msd"
x0_range = [[10.0, 20.0], [-1.0, 1.0]]
t_end = 4.0

[grid]
sigma = [0.0, 0.1]
dt = [1e-3, 2e-3]
r = [20.0, 220.0]
detector = ["paper", "residual"]

[summary]
baseline = { detector = "paper", r = 220.0 }

[run]
trials = 4
seed = 11
)";

SweepOutcome Run(const SweepConfig& c, const fs::path& out, int threads, Shard shard = {},
                 const std::atomic<bool>* stop = nullptr) {
  SweepOptions o;
  o.out = out;
  o.threads = threads;
  o.shard = shard;
  o.progress = Progress::Mode::kNone;
  return RunSweep(c, Registry(), o, stop);
}

// The error of a sweep file's text read as `name` (model files are found relative to its folder).
std::string ErrorOf(const std::string& text, const std::string& name = "bad.toml") {
  try {
    ParseSweepText(text, name, Registry());
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST_CASE("sweep files: every error names file, line and key", "[sweep][config]") {
  const std::string head = "[model]\nname = \"impact-msd\"\n";
  CHECK_THAT(ErrorOf(head + "[grid]\nsigma = [0.1]\ndt = [1e-3]\nfoo = 1\n"),
             Catch::Contains("bad.toml:6: grid.foo: unknown key"));
  CHECK_THAT(ErrorOf(head + "[grid]\nsigma = []\ndt = [1e-3]\n"),
             Catch::Contains("bad.toml:4: grid.sigma: empty: give at least one value"));
  CHECK_THAT(ErrorOf(head + "[grid]\nsigma = [0.1]\ndt = [1e-3, -1e-3]\n"),
             Catch::Contains("bad.toml:5: grid.dt: -0.001 must be > 0"));
  CHECK_THAT(ErrorOf(head + "[grid]\nsigma = [0.1]\ndt = 0\n"),
             Catch::Contains("bad.toml:5: grid.dt: 0 must be > 0"));
  CHECK_THAT(ErrorOf(head + "[grid]\nsigma = [-0.1]\ndt = 1e-3\n"),
             Catch::Contains("bad.toml:4: grid.sigma: -0.1 must be ≥ 0"));
  CHECK_THAT(ErrorOf(head + "[grid]\nsigma = 0\ndt = 1e-3\nr = [1.0]\n"),
             Catch::Contains("bad.toml:6: grid.r: 1 must be > 1"));
  CHECK_THAT(ErrorOf(head + "[grid]\nsigma = \"big\"\ndt = 1e-3\n"),
             Catch::Contains("bad.toml:4: grid.sigma: expected a number, a list"));
  CHECK_THAT(ErrorOf(head + "[grid]\nsigma = 0\ndt = 1e-3\nestimator = [\"kalman\"]\n"),
             Catch::Contains("bad.toml:6: grid.estimator: unknown estimator 'kalman'"));
  CHECK_THAT(ErrorOf("[model]\nname = \"pendulum\"\n[grid]\nsigma = 0\ndt = 1e-3\n"),
             Catch::Contains("bad.toml:2: model.name: unknown model 'pendulum'"));
  CHECK_THAT(ErrorOf(head + "x0 = [1.0]\n[grid]\nsigma = 0\ndt = 1e-3\n"),
             Catch::Contains("bad.toml:3: model.x0: has 1 entries, expected 2 (one per state of model 'impact-msd')"));
  CHECK_THAT(ErrorOf(head + "params = { k = 1.0 }\n[grid]\nsigma = 0\ndt = 1e-3\n"),
             Catch::Contains("bad.toml:3: model.params.k:"));
  CHECK_THAT(ErrorOf(head + "[grid]\nsigma = 0\ndt = 1e-3\n[run]\ntrials = 0\n"),
             Catch::Contains("bad.toml:7: run.trials: 0 must be ≥ 1"));
  CHECK_THAT(ErrorOf(head + "[grid]\nsigma = 0\ndt = 1e-3\n[run]\ntrials = 1.5\n"),
             Catch::Contains("bad.toml:7: run.trials: expected an integer"));
  CHECK_THAT(ErrorOf(head + "[grid]\nsigma = 0\ndt = 1e-3\n[identifier]\nfalse_alarm = 2.0\n"),
             Catch::Contains("bad.toml:7: identifier.false_alarm:"));
  CHECK_THAT(ErrorOf(head + "[grid]\nsigma = 0\ndt = 1e-3\nfalse_alarm = [0.7]\n"),
             Catch::Contains("bad.toml:6: grid.false_alarm: 0.7 must be in (0, 0.5)"));
  CHECK_THAT(ErrorOf(head + "[grid]\nsigma = 0\ndt = [1e-3, 1e-3]\n"),
             Catch::Contains("bad.toml:5: grid.dt: 0.001 appears twice"));
  CHECK_THAT(ErrorOf(head + "[grid]\nsigma = 0\n"), Catch::Contains("bad.toml:3: grid.dt: missing"));
  CHECK_THAT(ErrorOf(head + "[grid\n"), Catch::Contains("bad.toml:3: TOML syntax"));
  CHECK_THAT(ErrorOf(head + "t_end = 1.0\n[grid]\nsigma = 0\ndt = 0.6\n"),
             Catch::Contains("grid.dt: 0.6 leaves fewer than 3 samples"));
  const fs::path empty = TempDir("empty") / "empty.toml";
  std::ofstream(empty) << "\n";
  CHECK_THROWS_WITH(ParseSweepFile(empty, Registry()), Catch::Contains("empty.toml: empty sweep file"));
  CHECK_THROWS_WITH(ParseSweepFile("/nonexistent/x.toml", Registry()),
                    Catch::Contains("/nonexistent/x.toml: cannot read the sweep file: No such file"));
}

TEST_CASE("sweep files: ranges, defaults and cells", "[sweep][config]") {
  const SweepConfig c = ParseSweepText(
      "[model]\nname = \"impact-msd\"\n[grid]\nsigma = { from = 0.0, to = 0.3, count = 4 }\n"
      "dt = { from = 1e-4, to = 1e-2, count = 3, log = true }\nr = [5.0, 50.0]\n"
      "detector = [\"paper\", \"residual\"]\n",
      "ok.toml", Registry());
  REQUIRE(c.grid.sigma.size() == 4);
  CHECK(c.grid.sigma[2] == Approx(0.2));
  REQUIRE(c.grid.dt.size() == 3);
  CHECK(c.grid.dt[1] == Approx(1e-3));
  // Computed grid values are the short decimals a user types (0.1, not 0.10000000000000006).
  CHECK(c.grid.sigma[1] == 0.1);
  CHECK(c.grid.dt[1] == 1e-3);
  const SweepConfig log_grid = ParseSweepText(
      "[model]\nname = \"impact-msd\"\n[grid]\nsigma = { from = 0.01, to = 1.0, count = 5, log = true }\ndt "
      "= 1e-3\n",
      "ok.toml", Registry());
  CHECK(log_grid.grid.sigma == std::vector<double>{0.01, 0.0316227766017, 0.1, 0.316227766017, 1.0});
  CHECK(c.models[0].x0 == std::vector<double>{20.0, 0.0});  // the model's default
  CHECK(c.trials == 10);
  // residual ignores r: one cell per (δt, σ), paper one per r.
  const auto cells = EnumerateCells(c);
  CHECK(cells.size() == 3u * 4u * (2u + 1u));
  long residual = 0;
  for (const auto& cell : cells) residual += cell.detector == DetectorKind::kResidual ? 1 : 0;
  CHECK(residual == 12);
  // Hash: equal configs equal, any change differs.
  // false_alarm is expanded for the residual detector only.
  const SweepConfig e = ParseSweepText(
      "[model]\nname = \"impact-msd\"\n[grid]\nsigma = [0.0, 0.1]\ndt = 1e-3\nr = [5.0, 50.0, 500.0]\n"
      "false_alarm = [1e-6, 1e-8]\ndetector = [\"paper\", \"residual\"]\n",
      "ok.toml", Registry());
  const auto ecells = EnumerateCells(e);
  CHECK(ecells.size() == 2u * (3u + 2u));
  for (const auto& cell : ecells) {
    CHECK(std::isnan(cell.option(e.grid, "r")) == (cell.detector == DetectorKind::kResidual));
    CHECK(std::isnan(cell.option(e.grid, "false_alarm")) == (cell.detector == DetectorKind::kPaper));
  }
  const SweepConfig d = ParseSweepText(
      "[model]\nname = \"impact-msd\"\n[grid]\nsigma = { from = 0.0, to = 0.3, count = 4 }\n"
      "dt = { from = 1e-4, to = 1e-2, count = 3, log = true }\nr = [5.0, 50.0]\n"
      "detector = [\"paper\", \"residual\"]\n[run]\nseed = 2\n",
      "ok.toml", Registry());
  CHECK(c.Hash() != ParseSweepText(kSweep, "a", Registry()).Hash());
  CHECK(c.Hash() != d.Hash());
}

TEST_CASE("sweep files: option keys from the option tables, and oracle labels", "[sweep][config]") {
  const std::string head = "[model]\nname = \"impact-msd\"\n";
  // Every estimator option, for the α estimator and (jump_NAME) the β estimator; choices by name.
  const SweepConfig c =
      ParseSweepText(head +
                         "[grid]\nsigma = 0.1\ndt = 1e-3\nestimator = \"frisch\"\n"
                         "[identifier]\nfrisch_box = \"intersect\"\njump_window = 50\n"
                         "frisch_confidence = 0.0\nbound = \"homogeneous\"\noracle = true\n",
                     "ok.toml", Registry());
  CHECK(c.identifier.flow_estimator.frisch_box == FrischBox::kIntersect);
  CHECK(c.identifier.jump_estimator.frisch_box == FrischBox::kCumulative);
  CHECK(c.identifier.flow_estimator.window == 200);
  CHECK(c.identifier.jump_estimator.window == 50);
  CHECK(c.identifier.flow_estimator.frisch_confidence == 0.0);
  CHECK(c.identifier.detector.bound == BoundRule::kHomogeneous);
  CHECK(c.oracle);
  CHECK_THAT(ErrorOf(head + "[grid]\nsigma = 0\ndt = 1e-3\n[identifier]\nfrisch_box = \"union\"\n"),
             Catch::Contains("bad.toml:7: identifier.frisch_box: 'union' must be one of"));
  CHECK_THAT(ErrorOf(head + "[grid]\nsigma = 0\ndt = 1e-3\n[identifier]\njump_window = -1\n"),
             Catch::Contains("identifier.jump_window: -1 must be >= 0"));
  // With the true labels nothing of a detector may be varied.
  CHECK_THAT(ErrorOf(head + "[grid]\nsigma = 0\ndt = 1e-3\nr = [5.0, 20.0]\n[identifier]\noracle = true\n"),
             Catch::Contains("grid.r: not used with identifier.oracle = true"));
  // The oracle's rows: detector "oracle", every jump found, no false one, at σ = 0.1.
  const SweepConfig o = ParseSweepText(head +
                                           "t_end = 4.0\n[grid]\nsigma = 0.1\ndt = 1e-3\n"
                                           "[identifier]\noracle = true\nsets = false\n[run]\ntrials = 2\n",
                                       "oracle.toml", Registry());
  const fs::path dir = TempDir("oracle");
  Run(o, dir, 1);
  std::vector<std::string> header;
  std::map<long, std::vector<std::string>> rows;
  ReadTrialsCsv(dir / "trials.csv", &header, &rows);
  const auto col = [&](const char* name) {
    return static_cast<std::size_t>(std::find(header.begin(), header.end(), name) - header.begin());
  };
  REQUIRE(rows.size() == 2u);
  for (const auto& [unit, r] : rows) {
    CHECK(r[col("detector")] == "oracle");
    CHECK(r[col("fp")] == "0");
    CHECK(r[col("fn")] == "0");
    CHECK(r[col("jumps_detected")] == r[col("jumps_true")]);
  }
}

TEST_CASE("summary statistics against closed forms", "[sweep][summary]") {
  const MetricSummary s = Summarize({4.0, 1.0, 3.0, 2.0});
  CHECK(s.n == 4);
  CHECK(s.mean == Approx(2.5));
  CHECK(s.median == Approx(2.5));
  CHECK(s.std == Approx(std::sqrt(5.0 / 3.0)));
  // t(0.975, 3) = 3.182446305284263
  CHECK(s.ci_hi - s.mean == Approx(3.182446305284263 * std::sqrt(5.0 / 3.0) / 2.0).epsilon(1e-9));
  const MetricSummary one = Summarize({7.0});
  CHECK(one.mean == 7.0);
  CHECK(std::isnan(one.std));
  CHECK(std::isnan(one.ci_lo));
}

TEST_CASE("sweep: trials.csv is byte-identical for 1 and 2 threads", "[sweep][determinism]") {
  const SweepConfig c = ParseSweepText(kSweep, "det.toml", Registry());
  const fs::path a = TempDir("threads1"), b = TempDir("threads2");
  const SweepOutcome oa = Run(c, a, 1), ob = Run(c, b, 2);
  CHECK(oa.units_run == 48);
  CHECK(ob.units_run == 48);
  // Trajectories are shared: one per (δt, drawn x0) = 2 × 4, not one per trial.
  CHECK(oa.trajectories == 8);
  CHECK(Slurp(a / "trials.csv") == Slurp(b / "trials.csv"));
  CHECK(Slurp(a / "summary.csv") == Slurp(b / "summary.csv"));
  // Noise differs between trials and cells; σ = 0 cells see none.
  std::vector<std::string> header;
  std::map<long, std::vector<std::string>> rows;
  ReadTrialsCsv(a / "trials.csv", &header, &rows);
  REQUIRE(rows.size() == 48u);
  const auto col = [&](const char* n) { return std::find(header.begin(), header.end(), n) - header.begin(); };
  long inconsistent = 0;
  for (const auto& [id, r] : rows) {
    // A paper detector that misses the impacts leaves them in the flow regression: its trial's
    // recursive estimate contradicts the data (core/identify/self_check.hpp), status inconsistent,
    // with the detector's counts kept. The residual detector finds them: ok.
    const std::string& status = r[static_cast<std::size_t>(col("status"))];
    CHECK((status == "ok" || status == "inconsistent"));
    if (status == "inconsistent") {
      ++inconsistent;
      CHECK(r[static_cast<std::size_t>(col("detector"))] == "paper");
      CHECK_FALSE(r[static_cast<std::size_t>(col("jumps_detected"))].empty());
      continue;
    }
    // Set metrics (sets are on by default): noise-free, D̂ lies within δt·max|ξ2| of D (|ξ2| < 50
    // from these initial states) and no part of Ĉ is outside C.
    if (r[static_cast<std::size_t>(col("sigma"))] == "0") {
      const double dt = std::stod(r[static_cast<std::size_t>(col("dt"))]);
      const std::string& hd = r[static_cast<std::size_t>(col("jump_hausdorff"))];
      if (r[static_cast<std::size_t>(col("jumps_detected"))] == "0") {
        CHECK(hd.empty());
      } else {
        CHECK(std::stod(hd) < 50 * dt);
      }
      CHECK(r[static_cast<std::size_t>(col("flow_outside_share"))] == "0");
    }
  }
  CHECK(inconsistent > 0);
  CHECK(inconsistent < 48);
  // Initial states are drawn in the ranges and shared by trial i of every cell.
  CHECK(rows[0][static_cast<std::size_t>(col("x0_1"))] == rows[4][static_cast<std::size_t>(col("x0_1"))]);
  CHECK(rows[0][static_cast<std::size_t>(col("x0_1"))] != rows[1][static_cast<std::size_t>(col("x0_1"))]);
  const double x01 = std::stod(rows[3][static_cast<std::size_t>(col("x0_1"))]);
  CHECK((x01 >= 10.0 && x01 <= 20.0));
}

TEST_CASE("sweep: a killed run resumes to exactly the uninterrupted rows", "[sweep][resume]") {
  const SweepConfig c = ParseSweepText(kSweep, "resume.toml", Registry());
  const fs::path full = TempDir("full"), cut = TempDir("cut");
  Run(c, full, 2);
  // A run killed mid-write: the first rows of the journal, then half a line.
  const std::string journal = Slurp(full / "trials.journal");
  std::size_t pos = 0;
  for (int i = 0; i < 2 + 17; ++i) pos = journal.find('\n', pos) + 1;
  const std::size_t torn = journal.find('\n', pos) - 20;
  fs::copy_file(full / "sweep.json", cut / "sweep.json");
  std::ofstream(cut / "trials.journal", std::ios::binary) << journal.substr(0, torn);
  const SweepOutcome o = Run(c, cut, 2);
  CHECK(o.units_resumed == 17);
  CHECK(o.units_run == 48 - 17);
  CHECK(Slurp(cut / "trials.csv") == Slurp(full / "trials.csv"));
  CHECK(Slurp(cut / "summary.csv") == Slurp(full / "summary.csv"));
  // Running a finished sweep again runs nothing and writes the same tables.
  const SweepOutcome again = Run(c, cut, 1);
  CHECK(again.units_run == 0);
  CHECK(Slurp(cut / "trials.csv") == Slurp(full / "trials.csv"));
  // The stop flag (SIGINT) leaves a resumable journal and no tables.
  const fs::path stopped = TempDir("stopped");
  std::atomic<bool> stop{true};
  const SweepOutcome s = Run(c, stopped, 2, {}, &stop);
  CHECK(s.interrupted);
  CHECK_FALSE(fs::exists(stopped / "trials.csv"));
  Run(c, stopped, 2);
  CHECK(Slurp(stopped / "trials.csv") == Slurp(full / "trials.csv"));
  // A different configuration is refused in the same directory.
  const SweepConfig other = ParseSweepText(std::string(kSweep) + "", "resume.toml", Registry());
  SweepConfig changed = other;
  changed.seed = 12;
  CHECK_THROWS_WITH(Run(changed, cut, 1), Catch::Contains("holds another study"));
  // A malformed row before the end is an error naming the journal line.
  const fs::path bad = TempDir("badjournal");
  fs::copy_file(full / "sweep.json", bad / "sweep.json");
  std::string broken = journal;
  broken.insert(journal.find('\n', journal.find('\n') + 1) + 1, "garbage\n");
  std::ofstream(bad / "trials.journal", std::ios::binary) << broken;
  CHECK_THROWS_WITH(Run(c, bad, 1), Catch::Contains("trials.journal:3: malformed journal row"));
}

namespace {

// The journal's lines (identity, columns, rows).
std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::stringstream ss(text);
  for (std::string l; std::getline(ss, l);) lines.push_back(l);
  return lines;
}

std::string Unlines(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += l + "\n";
  return s;
}

// A run directory holding `journal` (and sweep.json unless `with_identity` is false).
fs::path Planted(const std::string& name, const fs::path& from, const std::string& journal,
                 bool with_identity) {
  const fs::path dir = TempDir(name);
  if (with_identity) fs::copy_file(from / "sweep.json", dir / "sweep.json");
  std::ofstream(dir / "trials.journal", std::ios::binary) << journal;
  return dir;
}

}  // namespace

TEST_CASE("sweep: a corrupt or foreign journal never reaches trials.csv", "[sweep][journal]") {
  const SweepConfig c = ParseSweepText(kSweep, "journal.toml", Registry());
  SweepConfig other = c;
  other.seed = 99;  // another sweep: same cells, other noise
  const fs::path full = TempDir("jfull"), foreign = TempDir("jforeign");
  Run(c, full, 2);
  Run(other, foreign, 2);
  const std::vector<std::string> mine = Lines(Slurp(full / "trials.journal"));
  const std::vector<std::string> theirs = Lines(Slurp(foreign / "trials.journal"));
  REQUIRE(mine.size() == 2 + 48);
  CHECK_THAT(mine[0], Catch::StartsWith("# hysid journal sweep=" + c.Hash() + " shard=1/1"));
  CHECK_THAT(mine[5], Catch::EndsWith(std::string(",").append(c.Hash())));

  // Another sweep's journal, with sweep.json deleted: refused by its first line.
  CHECK_THROWS_WITH(Run(c, Planted("j1", full, Slurp(foreign / "trials.journal"), false), 1),
                    Catch::Contains("trials.journal:1: the journal is of another sweep or shard"));
  // A foreign row for a unit missing from ours (its first line forged to ours): refused by its hash.
  {
    std::vector<std::string> lines(mine.begin(), mine.begin() + 10);
    lines.push_back(theirs[20]);
    CHECK_THROWS_WITH(
        Run(c, Planted("j2", full, Unlines(lines), true), 1),
        Catch::Contains("trials.journal:11: the row of unit") && Catch::Contains("a foreign row"));
  }
  // A foreign duplicate placed first, its hash rewritten to ours: refused as a different duplicate.
  {
    std::vector<std::string> lines(mine.begin(), mine.begin() + 2);
    std::string forged = theirs[2].substr(0, theirs[2].rfind(',') + 1) + c.Hash();
    lines.push_back(forged);
    lines.insert(lines.end(), mine.begin() + 2, mine.end());
    const std::string first_unit = forged.substr(0, forged.find(','));
    const bool same = forged.substr(0, forged.rfind(',')) == mine[2].substr(0, mine[2].rfind(','));
    if (!same) {
      CHECK_THROWS_WITH(Run(c, Planted("j3", full, Unlines(lines), true), 1),
                        Catch::Contains("appears again (first on line 3) with different content"));
    }
  }
  // A row claiming a unit id whose plan differs (cell/trial/keys), or beyond the sweep.
  {
    // Unit 47's row replaced by another unit's row relabelled 47.
    std::vector<std::string> lines(mine.begin(), mine.end());
    const auto unit_of = [](const std::string& l) { return l.substr(0, l.find(',')); };
    const auto it47 =
        std::find_if(lines.begin() + 2, lines.end(), [&](const auto& l) { return unit_of(l) == "47"; });
    REQUIRE(it47 != lines.end());
    const std::string& other_row = unit_of(lines[2]) == "47" ? lines[3] : lines[2];
    const std::string moved = "47" + other_row.substr(other_row.find(','));
    *it47 = moved;
    CHECK_THROWS_WITH(Run(c, Planted("j4", full, Unlines(lines), true), 1),
                      Catch::Contains("the row of unit 47 has") && Catch::Contains("the plan has"));
    const std::string beyond = "4800" + mine[3].substr(mine[3].find(','));
    std::vector<std::string> b(mine.begin(), mine.begin() + 3);
    b.push_back(beyond);
    CHECK_THROWS_WITH(Run(c, Planted("j5", full, Unlines(b), true), 1),
                      Catch::Contains("is beyond the sweep's 48 units"));
  }
  // An identical duplicate (a unit run twice) and a torn last line: resumed to the exact table.
  {
    std::vector<std::string> lines(mine.begin(), mine.begin() + 20);
    lines.push_back(mine[5]);
    std::string text = Unlines(lines) + mine[20].substr(0, 30);
    const fs::path dir = Planted("j6", full, text, true);
    const SweepOutcome o = Run(c, dir, 2);
    CHECK(o.units_resumed == 18);
    CHECK(Slurp(dir / "trials.csv") == Slurp(full / "trials.csv"));
  }
  // A torn line in the middle (two writers interleaved): refused, not guessed.
  {
    std::vector<std::string> lines(mine.begin(), mine.end());
    lines[10] = lines[10].substr(0, 25) + lines[11];
    CHECK_THROWS_WITH(Run(c, Planted("j7", full, Unlines(lines), true), 1),
                      Catch::Contains("trials.journal:11: malformed journal row"));
  }
  // Two writers: the directory is locked while a run holds it.
  {
    const DirectoryLock held(full);
    CHECK_THROWS_WITH(Run(c, full, 1), Catch::Contains("another hysid process is running in this directory"));
  }
  CHECK_NOTHROW(Run(c, full, 1));
}

TEST_CASE("sweep: sizes are checked against named limits before allocation", "[sweep][limits]") {
  const std::string base = "[model]\nname = \"impact-msd\"\n[grid]\nsigma = 0.0\n";
  CHECK_THAT(ErrorOf(base + "dt = 1e-3\n[run]\ntrials = 4611686018427387904\n"),
             Catch::Contains("run.trials: 4611686018427387904 exceeds the limit of 10000000 units") &&
                 Catch::Contains("HYSID_MAX_TRIALS"));
  CHECK_THAT(
      ErrorOf(base + "dt = { from = 1e-4, to = 1e-3, count = 1000000000000 }\n"),
      Catch::Contains("bad.toml:5: grid.dt.count: 1000000000000 exceeds the limit of 100000 values per grid "
                      "axis (raise it with HYSID_MAX_AXIS_VALUES=N)"));
  CHECK_THAT(ErrorOf(base + "dt = 1e-9\n"),
             Catch::Contains("samples per trajectory") && Catch::Contains("HYSID_MAX_SAMPLES"));
  // 10 000 cells × 10 000 trials: within each limit alone, beyond the product's.
  const SweepConfig big =
      ParseSweepText(base + "dt = 1e-3\nr = { from = 2, to = 300, count = 10000 }\n[run]\ntrials = 10000\n",
                     "big.toml", Registry());
  CHECK_THROWS_WITH(Run(big, TempDir("big"), 1),
                    Catch::Contains("10000 cells × 10000 trials") && Catch::Contains("HYSID_MAX_TRIALS"));
  // TOML integers: read as 64 bits and range-checked, the error quoting the value as written.
  CHECK_THAT(ErrorOf(base + "dt = 1e-3\n[simulator]\nmax_jumps = 4294967296\n"),
             Catch::Contains("simulator.max_jumps: 4294967296 must be ≤ 2147483647"));
  CHECK_THAT(ErrorOf(base + "dt = 1e-3\n[identifier]\nwindow = -4294967296\n"),
             Catch::Contains("identifier.window: -4294967296 must be >= 0"));
  CHECK_THAT(ErrorOf(base + "dt = 1e-3\n[identifier]\nwindow = 4294967296\n"),
             Catch::Contains("identifier.window: 4294967296 must be at most 2147483647 in magnitude"));
  // The simulator's tolerances, in the file's terms.
  CHECK_THAT(ErrorOf(base + "dt = 1e-3\n[simulator]\nrtol = -1.0\n"),
             Catch::Contains("bad.toml:7: simulator.rtol: -1 must be > 0"));
  CHECK_THAT(ErrorOf(base + "dt = 1e-3\n[simulator]\natol = 0\n"), Catch::Contains("bad.toml:7: simulator.atol: 0 must be > 0"));
  CHECK_THAT(ErrorOf(base + "dt = 1e-3\n[run]\nseed = -1\n"), Catch::Contains("run.seed: -1 must be ≥ 0"));
}

TEST_CASE("journal: names with commas, quotes and line breaks are recovered, a torn quoted tail is cut",
          "[sweep][journal]") {
  const fs::path dir = TempDir("journal-names");
  const fs::path path = dir / "trials.journal";
  const std::vector<std::string> header{"unit", "model", "k,\"1\"\nnew", "wall_ms"};
  const std::vector<std::vector<std::string>> rows{
      {"0", "wall,msd", "a \"quoted\"\nvalue", "1.5"}, {"1", " edge ", "", "2"}, {"2", "plain", "\r", "3"}};
  {
    Journal journal(path, header, "feedbeef00000000", "1/1");
    for (const auto& r : rows) journal.Append(r);
  }
  // Every prefix of the file: the complete records before it are recovered, the rest cut off.
  const std::string full = Slurp(path);
  const std::size_t head = full.find("wall_ms,sweep\n") + std::string("wall_ms,sweep\n").size();
  for (std::size_t cut = head; cut <= full.size(); ++cut) {
    std::ofstream(path, std::ios::binary | std::ios::trunc) << full.substr(0, cut);
    const Journal journal(path, header, "feedbeef00000000", "1/1");
    std::size_t complete = 0;
    for (std::size_t end = head; end < cut; ++complete) {
      const std::size_t next = full.find(",feedbeef00000000\n", end);
      if (next == std::string::npos || next + 18 > cut) break;
      end = next + 18;
    }
    INFO("cut at byte " << cut);
    REQUIRE(journal.recovered().size() == complete);
    for (std::size_t i = 0; i < complete; ++i) CHECK(journal.recovered().at(static_cast<long>(i)) == rows[i]);
  }
}

TEST_CASE("merge refuses an input directory as its output", "[sweep][shard]") {
  const SweepConfig c = ParseSweepText(kSweep, "mergeout.toml", Registry());
  const fs::path a = TempDir("mo1"), b = TempDir("mo2");
  Run(c, a, 1, Shard{1, 2});
  Run(c, b, 1, Shard{2, 2});
  const std::string before = Slurp(a / "trials.csv");
  CHECK_THROWS_WITH(MergeShards({a, b}, a / "."), Catch::Contains("is one of the shard directories"));
  CHECK(Slurp(a / "trials.csv") == before);
}

TEST_CASE("sweep: shards merged equal the unsharded run", "[sweep][shard]") {
  const SweepConfig c = ParseSweepText(kSweep, "shard.toml", Registry());
  const fs::path full = TempDir("unsharded");
  Run(c, full, 2);
  std::vector<fs::path> dirs;
  for (long k = 1; k <= 3; ++k) {
    dirs.push_back(TempDir("shard" + std::to_string(k)));
    const SweepOutcome o = Run(c, dirs.back(), 1, Shard{k, 3});
    CHECK(o.units_shard == 16);
  }
  const fs::path merged = TempDir("merged");
  MergeShards(dirs, merged);
  CHECK(Slurp(merged / "trials.csv") == Slurp(full / "trials.csv"));
  CHECK(Slurp(merged / "summary.csv") == Slurp(full / "summary.csv"));
  CHECK_THROWS_WITH(MergeShards({dirs[0], dirs[1]}, TempDir("merged2")),
                    Catch::Contains("shard 3/3 is missing"));
  CHECK_THROWS_WITH(MergeShards({dirs[0], dirs[0], dirs[1]}, TempDir("merged3")),
                    Catch::Contains("given twice"));
  CHECK_THROWS_WITH(MergeShards({dirs[0], full}, TempDir("merged4")),
                    Catch::Contains("does not split into 3"));
  CHECK_THROWS_WITH(ParseShard("3/2"), Catch::Contains("--shard = '3/2'"));
  CHECK_THROWS_WITH(ParseShard("x"), Catch::Contains("expected K/N"));
}

TEST_CASE("sweep: Zeno runs are rows with their status, not an aborted sweep", "[sweep][failures]") {
  // The ball's bounces accumulate at t = (1 + 2λ/(1 − λ))·sqrt(2h/g) ≈ 1.36 s for h = 1, λ = 0.5.
  const SweepConfig c = ParseSweepText(
      "[model]\nname = \"bouncing-ball\"\nparams = { lambda = 0.5 }\nx0 = [1.0, 0.0]\nt_end = 3.0\n"
      "[grid]\nsigma = [0.0, 0.01]\ndt = 1e-3\n[run]\ntrials = 2\n",
      "zeno.toml", Registry());
  const fs::path dir = TempDir("zeno");
  const SweepOutcome o = Run(c, dir, 2);
  CHECK(o.failures == 4);
  std::vector<std::string> header;
  std::map<long, std::vector<std::string>> rows;
  ReadTrialsCsv(dir / "trials.csv", &header, &rows);
  const auto col = [&](const char* n) {
    return static_cast<std::size_t>(std::find(header.begin(), header.end(), n) - header.begin());
  };
  for (const auto& [id, r] : rows) {
    CHECK(r[col("status")] == "zeno");
    CHECK_THAT(r[col("message")], Catch::Contains("Zeno: jumps accumulate at t = 1.35"));
    CHECK(r[col("e_alpha")].empty());
  }
  const std::string summary = Slurp(dir / "summary.csv");
  CHECK_THAT(summary, Catch::Contains(",2,2,"));  // trials, failures
}

TEST_CASE("sweep files: a model file instead of a registry name", "[sweep][config]") {
  const std::string sweep = std::string(HYSID_MODELS_DIR) + "/sweep.toml";  // files relative to it
  const SweepConfig c = ParseSweepText(
      "[model]\nfile = \"wall-msd.toml\"\nparams = { k = 3.0 }\n[grid]\nsigma = 0.0\ndt = 1e-3\nr = 5.0\n",
      sweep, Registry());
  REQUIRE(c.models.size() == 1u);
  CHECK(c.models[0].name == "wall-msd");
  CHECK(c.models[0].x0 == std::vector<double>{0.0, 5.0});  // the file's default
  const Model m = c.models[0].Build(Registry());
  CHECK(m.alpha()[1] == 3.0);
  const nlohmann::json definition = c.ToJson()["model"][0]["definition"];
  CHECK(definition["equations"].get<std::string>().find("h(xi) = x - 1 (rising), projected: x+ = 1") !=
        std::string::npos);
  CHECK(definition["alpha"][1] == nlohmann::json({{"name", "k"}, {"value", 4.0}, {"known", false}}));
  CHECK(definition["default_x0"] == nlohmann::json({0.0, 5.0}));
  CHECK_THROWS_WITH(
      ParseSweepText("[model]\nfile = \"nope.toml\"\n[grid]\nsigma = 0.0\ndt = 1e-3\n", sweep, Registry()),
      Catch::Contains("sweep.toml:2: model.file: ") && Catch::Contains("nope.toml: cannot read"));
  CHECK_THROWS_WITH(
      ParseSweepText(
          "[model]\nname = \"impact-msd\"\nfile = \"wall-msd.toml\"\n[grid]\nsigma = 0.0\ndt = 1e-3\n", sweep,
          Registry()),
      Catch::Contains("sweep.toml:3: model.file: give name or file, not both"));
}

TEST_CASE("sweep: cells share a trial's noise (σ a scale) and pair with their baseline", "[sweep][crn]") {
  const std::string text = R"(
[model]
name = "impact-msd"
x0 = [20.0, 0.0]
t_end = 3.0
[grid]
sigma = [0.05, 0.2]
dt = [1e-3, 2e-3]
r = [20.0, 220.0]
false_alarm = [1e-6, 1e-8]
detector = ["paper", "residual"]
[identifier]
sets = false
[summary]
baseline = { detector = "residual", false_alarm = 1e-8 }
[run]
trials = 3
seed = 5
)";
  const SweepConfig c = ParseSweepText(text, "crn.toml", Registry());
  const fs::path dir = TempDir("crn");
  Run(c, dir, 2);
  std::vector<std::string> header;
  std::map<long, std::vector<std::string>> rows;
  ReadTrialsCsv(dir / "trials.csv", &header, &rows);
  const auto col = [&](const char* n) {
    return static_cast<std::size_t>(std::find(header.begin(), header.end(), n) - header.begin());
  };
  const std::vector<SweepCell> cells = EnumerateCells(c);
  REQUIRE(cells.size() == 2u * 2u * 4u);
  // Independent computation of two units of trial 1 at δt = 2 ms with different σ and detector: the
  // stream TrialNoiseKey(seed, trial, model, δt) scaled by σ gives the sweep's estimates exactly.
  const Model model = c.models[0].Build(Registry());
  const Trajectory truth = Simulate(model, InitialState(c, 0, 1), SampleGrid{3.0, 2e-3}, c.simulator);
  Mat e(truth.x.rows(), truth.x.cols());
  FillStandardNormals(TrialNoiseKey(c, 0, 2e-3, 1), 0, e.data(), static_cast<std::size_t>(e.size()));
  long checked = 0;
  for (const SweepCell& cell : cells) {
    if (cell.dt != 2e-3) continue;
    IdentifierSettings s = c.identifier;
    cell.Apply(c.grid, &s);
    s.data_rtol = c.simulator.rtol;
    s.data_atol = c.simulator.atol;
    const Mat y = truth.x + cell.sigma * e;
    const IdentifyResult res = Identify(model, y, 2e-3, s);
    const auto& row = rows.at(cell.index * c.trials + 1);
    CHECK(row[col("alpha_hat_a")] == fmt::format("{}", res.alpha_hat[1]));
    CHECK(row[col("jumps_detected")] == fmt::format("{}", res.jumps_detected));
    ++checked;
  }
  CHECK(checked == 8);
  // The same normals as AddMeasurementNoise with that key.
  CHECK(AddMeasurementNoise(truth.x, Vec::Constant(2, 0.2), TrialNoiseKey(c, 0, 2e-3, 1)) ==
        truth.x + 0.2 * e);

  // Paired differences: every cell's baseline is the residual detector at false_alarm = 1e-8 with its δt
  // and σ; the differences recomputed from trials.csv over the trials ok in both cells.
  std::vector<std::string> sh;
  std::map<long, std::vector<std::string>> summary;
  {
    const fs::path tmp = dir / "summary_as_trials.csv";
    // summary.csv's first column is the cell id: read it with the trials reader.
    fs::copy_file(dir / "summary.csv", tmp);
    ReadTrialsCsv(tmp, &sh, &summary);
  }
  const auto scol = [&](const char* n) {
    return static_cast<std::size_t>(std::find(sh.begin(), sh.end(), n) - sh.begin());
  };
  long paired = 0;  // cells whose 3 trials pair with their baseline's
  for (const SweepCell& cell : cells) {
    long expected = -1;
    for (const SweepCell& b : cells) {
      if (b.dt == cell.dt && b.sigma == cell.sigma && b.detector == DetectorKind::kResidual &&
          b.option(c.grid, "false_alarm") == 1e-8) {
        expected = b.index;
      }
    }
    const auto& srow = summary.at(cell.index);
    CHECK(srow[scol("baseline_cell")] == fmt::format("{}", expected));
    std::vector<double> d;
    for (long t = 0; t < c.trials; ++t) {
      const std::string& a = rows.at(cell.index * c.trials + t)[col("e_alpha")];
      const std::string& b = rows.at(expected * c.trials + t)[col("e_alpha")];
      if (!a.empty() && !b.empty()) d.push_back(std::stod(a) - std::stod(b));
    }
    CHECK(srow[scol("e_alpha_diff_n")] == fmt::format("{}", d.size()));
    if (d.size() == 3) {
      ++paired;
      const MetricSummary ms = Summarize(d);
      CHECK(srow[scol("e_alpha_diff_mean")] == fmt::format("{}", ms.mean));
      CHECK(srow[scol("e_alpha_diff_ci95_hi")] == fmt::format("{}", ms.ci_hi));
    }
    if (cell.index == expected) CHECK(srow[scol("e_alpha_diff_mean")] == "0");
  }
  CHECK(paired >= 8);  // the residual cells at least

  // Baseline errors: name the file, the key and the constraint.
  const std::string head =
      "[model]\nname = \"impact-msd\"\n[grid]\nsigma = [0.1]\ndt = 1e-3\nr = [20.0, 220.0]\n"
      "detector = [\"paper\", \"residual\"]\n[summary]\n";
  CHECK_THAT(ErrorOf(head + "baseline = { detector = \"kalman\" }\n"),
             Catch::Contains("bad.toml:9: summary.baseline.detector: 'kalman' is not on grid.detector"));
  CHECK_THAT(ErrorOf(head + "baseline = { r = 50.0 }\n"),
             Catch::Contains("summary.baseline.r: 50 is not on grid.r"));
  CHECK_THAT(ErrorOf(head + "baseline = { dt = 1e-3 }\n"),
             Catch::Contains("summary.baseline.dt: unknown key"));
  CHECK_THAT(ErrorOf(head + "baseline = { detector = \"residual\", r = 20.0 }\n"),
             Catch::Contains("summary.baseline.r: detector 'residual' does not use r"));
  const SweepConfig ambiguous =
      ParseSweepText(head + "baseline = { detector = \"paper\" }\n", "amb.toml", Registry());
  CHECK_THROWS_WITH(Run(ambiguous, TempDir("amb"), 1), Catch::Contains("matches several cells"));
}

TEST_CASE("sweep: per-parameter relative errors from the estimate columns, and their cell means",
          "[sweep][summary]") {
  const SweepConfig c = ParseSweepText(R"(
[model]
name = "impact-msd"
params = { a = 4.0, b = 0.2, lambda = 0.9, mu = 0.0 }
x0 = [15.0, 0.0]
t_end = 4.0

[grid]
sigma = [0.0, 0.05]
dt = [1e-3]
estimator = ["rls", "gtls"]

[run]
trials = 3
seed = 5
)",
                                       "rel.toml", Registry());
  const fs::path dir = TempDir("relative_errors");
  Run(c, dir, 2);
  std::vector<std::string> header;
  std::map<long, std::vector<std::string>> rows;
  ReadTrialsCsv(dir / "trials.csv", &header, &rows);
  const auto col = [&](const std::string& n) {
    const auto it = std::find(header.begin(), header.end(), n);
    REQUIRE(it != header.end());
    return static_cast<std::size_t>(it - header.begin());
  };
  // The true values written above; μ = 0 has the absolute error.
  const std::vector<std::tuple<std::string, std::string, double>> params{{"a", "alpha_hat_a", 4.0},
                                                                         {"b", "alpha_hat_b", 0.2},
                                                                         {"lambda", "beta_hat_lambda", 0.9},
                                                                         {"mu", "beta_hat_mu", 0.0}};
  std::map<std::string, std::map<std::string, std::vector<double>>> by_cell;  // cell → name → values
  for (const auto& [id, r] : rows) {
    REQUIRE(r[col("status")] == "ok");
    for (const auto& [name, hat_col, truth] : params) {
      const double hat = std::stod(r[col(hat_col)]);
      const double expected = truth != 0 ? std::fabs(hat - truth) / std::fabs(truth) : std::fabs(hat - truth);
      const double got = std::stod(r[col("rel_err_" + name)]);
      CHECK(got == Approx(expected).epsilon(1e-15).margin(1e-300));
      by_cell[r[col("cell")]][name].push_back(got);
    }
  }
  // summary.csv: the mean of each cell's rel_err_NAME column, with a Student-t interval around it.
  std::vector<std::string> sh;
  std::map<long, std::vector<std::string>> srows;
  ReadTrialsCsv(dir / "summary.csv", &sh, &srows);  // keyed by the first column, "cell"
  REQUIRE(srows.size() == 4u);
  const auto scol = [&](const std::string& n) {
    const auto it = std::find(sh.begin(), sh.end(), n);
    REQUIRE(it != sh.end());
    return static_cast<std::size_t>(it - sh.begin());
  };
  for (const auto& [cell, r] : srows) {
    for (const auto& [name, hat_col, truth] : params) {
      const std::vector<double>& v = by_cell[std::to_string(cell)][name];
      REQUIRE(v.size() == 3u);
      const double mean = (v[0] + v[1] + v[2]) / 3.0;
      CHECK(std::stod(r[scol("rel_err_" + name + "_mean")]) == Approx(mean).epsilon(1e-12).margin(1e-300));
      const std::string lo = r[scol("rel_err_" + name + "_ci95_lo")],
                        hi = r[scol("rel_err_" + name + "_ci95_hi")];
      if (!lo.empty()) {
        CHECK(std::stod(lo) <= mean);
        CHECK(std::stod(hi) >= mean);
      }
    }
  }
  // run.json records the true values the sweep used.
  const std::string run = Slurp(dir / "run.json");
  CHECK(run.find("\"models\"") != std::string::npos);
  CHECK(run.find("\"name\": \"lambda\"") != std::string::npos);
  CHECK(run.find("\"value\": 0.9") != std::string::npos);
}

TEST_CASE("sweep: refine as a baseline key pairs each refined cell with its recursive one", "[sweep][crn]") {
  const std::string text = R"(
[model]
name = "impact-msd"
x0 = [20.0, 0.0]
t_end = 3.0
[grid]
sigma = 0.05
dt = 1e-3
detector = "residual"
refine = ["none", "ml"]
[identifier]
sets = false
[summary]
baseline = { refine = "none" }
[run]
trials = 3
seed = 5
)";
  const SweepConfig c = ParseSweepText(text, "refine.toml", Registry());
  const fs::path dir = TempDir("refine_baseline");
  Run(c, dir, 2);
  std::vector<std::string> header, sh;
  std::map<long, std::vector<std::string>> rows, summary;
  ReadTrialsCsv(dir / "trials.csv", &header, &rows);
  fs::copy_file(dir / "summary.csv", dir / "summary_as_trials.csv");
  ReadTrialsCsv(dir / "summary_as_trials.csv", &sh, &summary);
  const auto col = [](const std::vector<std::string>& h, const char* n) {
    return static_cast<std::size_t>(std::find(h.begin(), h.end(), n) - h.begin());
  };
  const std::vector<SweepCell> cells = EnumerateCells(c);
  REQUIRE(cells.size() == 2u);
  long none = -1, ml = -1;
  for (const SweepCell& cell : cells) (cell.refine == "none" ? none : ml) = cell.index;
  REQUIRE((none >= 0 && ml >= 0));
  CHECK(summary.at(ml)[col(sh, "baseline_cell")] == fmt::format("{}", none));
  CHECK(summary.at(none)[col(sh, "baseline_cell")] == fmt::format("{}", none));
  std::vector<double> d;
  for (long t = 0; t < c.trials; ++t) {
    d.push_back(std::stod(rows.at(ml * c.trials + t)[col(header, "e_beta")]) -
                std::stod(rows.at(none * c.trials + t)[col(header, "e_beta")]));
  }
  CHECK(summary.at(ml)[col(sh, "e_beta_diff_mean")] == fmt::format("{}", Summarize(d).mean));
  CHECK(Summarize(d).mean < 0.0);  // the refinement improves on the recursive β̂ in this run

  const std::string head = "[model]\nname = \"impact-msd\"\n[grid]\nsigma = [0.1]\ndt = 1e-3\n";
  CHECK_THAT(ErrorOf(head + "refine = [\"none\", \"ml\"]\n[summary]\nbaseline = { refine = \"x\" }\n"),
             Catch::Contains("summary.baseline.refine: 'x' is not on grid.refine (none, ml)"));
  CHECK_THAT(ErrorOf(head + "[summary]\nbaseline = { refine = \"none\" }\n"),
             Catch::Contains("summary.baseline.refine: unknown key"));
}

TEST_CASE("sweep files: what the identifier refuses for a model is refused when the file is read", "[sweep][config]") {
  const std::string grid = "[grid]\nsigma = 0.0\ndt = 1e-2\n";
  auto error_of = [](const std::string& text) { return ErrorOf(text, HYSID_EXAMPLES_DIR "/study.toml"); };
  const std::string pump = "[model]\nfile = \"pump-tank/model.toml\"\n";
  CHECK_THAT(error_of(pump + grid + "[identifier]\nlocalize = true\n"),
             Catch::Contains("study.toml:7: identifier.localize: model 'pump-tank' is a hybrid automaton"));
  CHECK(error_of(pump + grid + "[identifier]\nlocalize = false\n") == "(no error)");
  CHECK_THAT(error_of("[[model]]\nname = \"impact-msd\"\n[[model]]\nfile = \"floor-ceiling/model.toml\"\n" + grid +
                      "[identifier]\nlocalize = true\n"),
             Catch::Contains("study.toml:9: identifier.localize: model[1] 'floor-ceiling' is a hybrid automaton"));
  CHECK_THAT(error_of("[model]\nfile = \"driven-oscillator/driven-oscillator.toml\"\n" + grid +
                      "[identifier]\nlocalize = true\n"),
             Catch::Contains("study.toml:7: identifier.localize: model 'driven-oscillator' has inputs"));
  CHECK(error_of("[model]\nname = \"impact-msd\"\n" + grid + "[identifier]\nlocalize = true\n") == "(no error)");
  // gtls and frisch derive their noise shape without the inputs: refused for a model with inputs.
  const std::string driven = "[model]\nfile = \"driven-oscillator/driven-oscillator.toml\"\n";
  CHECK_THAT(error_of(driven + grid + "estimator = [\"rls\", \"frisch\"]\n"),
             Catch::Contains("study.toml:6: grid.estimator: 'frisch' needs a noise shape, which is not derived for "
                             "model 'driven-oscillator' with inputs"));
  CHECK(error_of(driven + grid + "estimator = [\"rls\", \"integral\"]\n") == "(no error)");
  CHECK(error_of("[model]\nname = \"impact-msd\"\n" + grid + "estimator = \"gtls\"\n") == "(no error)");
}

TEST_CASE("sweep: a trial's units of one σ identified together give the rows each gives alone",
          "[sweep][lockstep]") {
  const std::string text = R"(
[model]
name = "impact-msd"
x0 = [20.0, 0.0]
t_end = 4.0
[grid]
sigma = [0.0, 0.02, 0.25]
dt = [5e-4]
r = [5.0, 20.0, 220.0, 1000.0]
false_alarm = [1e-6, 1e-8]
detector = ["paper", "residual"]
[identifier]
sets = false
[run]
trials = 2
seed = 3
)";
  const SweepConfig c = ParseSweepText(text, "lockstep.toml", Registry());
  std::vector<Model> models;
  for (const SweepModel& m : c.models) models.push_back(m.Build(Registry()));
  const std::vector<SweepCell> cells = EnumerateCells(c);
  const Vec x0 = Eigen::Vector2d(20.0, 0.0);
  const Trajectory truth = Simulate(models[0], x0, SampleGrid{4.0, 5e-4}, c.simulator);
  REQUIRE(truth.status.completed());
  for (long trial = 0; trial < c.trials; ++trial) {
    Mat normals(truth.x.rows(), truth.x.cols());
    FillStandardNormals(TrialNoiseKey(c, 0, 5e-4, trial), 0, normals.data(), static_cast<std::size_t>(normals.size()));
    for (const double sigma : c.grid.sigma) {
      INFO("trial " << trial << ", sigma " << sigma);
      std::vector<const SweepCell*> of_sigma;
      std::vector<long> units;
      for (const SweepCell& cell : cells) {
        if (cell.sigma != sigma) continue;
        of_sigma.push_back(&cell);
        units.push_back(UnitIndex({cell.index, trial}, c.trials));
      }
      REQUIRE(of_sigma.size() == 6);  // 4 r of the paper detector, 2 false-alarm probabilities
      NoisySamples shared, own;
      TrialInputs together_in;
      together_in.x0 = &x0;
      together_in.truth = &truth;
      together_in.normals = &normals;
      together_in.noisy = &shared;
      TrialInputs alone_in = together_in;
      alone_in.noisy = &own;
      const std::vector<std::vector<std::string>> together = RunTrials(c, models, of_sigma, units, trial, together_in);
      REQUIRE(together.size() == units.size());
      for (std::size_t i = 0; i < units.size(); ++i) {
        CHECK(together[i] == RunTrial(c, models, *of_sigma[i], units[i], trial, alone_in));
      }
    }
  }
}
