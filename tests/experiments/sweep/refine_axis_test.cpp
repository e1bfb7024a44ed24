// The sweep's refine axis and efficiency columns: refine = ["none", "ml"] adds refine, refine_status and
// the CRLB columns; the maximum-likelihood cells beat the recursive ones on the same noise (common
// random numbers pair them); crlb_e_alpha is the bound computed directly at the cell's σ (so linear in
// σ); summary.csv's efficiency is the mean error over it. A hybrid automaton's sweep adds the events
// against the truth and each jump map's β error and bound.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "core/builtin/builtin.hpp"
#include "core/model/registry.hpp"
#include "experiments/sweep/config.hpp"
#include "experiments/sweep/plan.hpp"
#include "experiments/sweep/runner.hpp"
#include "experiments/sweep/tables.hpp"
#include "experiments/sweep/trial.hpp"
#include "sim/sensitivity/crlb.hpp"
#include "tests/testing/temp_dir.hpp"

namespace fs = std::filesystem;
using namespace hysid;

namespace {

ModelRegistry Registry() {
  ModelRegistry r;
  RegisterBuiltinModels(r);
  return r;
}

const char* kSweep = R"(
[model]
name = "impact-msd"
x0 = [20.0, 0.0]
t_end = 3.0
[grid]
sigma = [0.05, 0.2]
dt = 1e-3
estimator = "rls"
detector = "residual"
refine = ["none", "ml"]
[identifier]
sets = false
[run]
trials = 3
seed = 7
)";

struct Table {
  std::vector<std::string> header;
  std::map<long, std::vector<std::string>> rows;
  const std::string& At(long row, const std::string& name) const {
    const auto it = std::find(header.begin(), header.end(), name);
    REQUIRE(it != header.end());
    return rows.at(row)[static_cast<std::size_t>(it - header.begin())];
  }
};

// A table of a run directory (trials.csv, summary.csv).
Table ReadTable(const fs::path& file) {
  Table t;
  ReadTrialsCsv(file, &t.header, &t.rows);
  return t;
}

// Runs sweep `c` into a fresh temporary directory named `name` (2 threads, no progress); returns it.
fs::path RunInTemp(const SweepConfig& c, const std::string& name) {
  const fs::path dir = testing::FreshTempDir(name);
  fs::remove_all(dir);
  SweepOptions o;
  o.out = dir;
  o.threads = 2;
  o.progress = Progress::Mode::kNone;
  RunSweep(c, Registry(), o, nullptr);
  return dir;
}

// A sweep of the example model file `file` (under examples/) with the extra [model] `lines`: σ = 1e-3,
// δt = dt, rls, residual detector, refine = ml, no sets, 2 trials from `seed`.
std::string ExampleSweep(const std::string& file, const std::string& lines, double dt, int seed) {
  return "[model]\nfile = \"" + std::string(HYSID_EXAMPLES_DIR) + "/" + file + "\"\n" + lines +
         "\n[grid]\nsigma = 1e-3\ndt = " + std::to_string(dt) +
         "\nestimator = \"rls\"\ndetector = \"residual\"\nrefine = \"ml\"\n[identifier]\nsets = false\n"
         "[run]\ntrials = 2\nseed = " + std::to_string(seed) + "\n";
}

}  // namespace

TEST_CASE("sweep: refine axis, paired ML gain and the CRLB columns", "[sweep][refine]") {
  const SweepConfig c = ParseSweepText(kSweep, "refine.toml", Registry());
  const std::vector<SweepCell> cells = EnumerateCells(c);
  REQUIRE(cells.size() == 4u);  // σ × refine, refine fastest
  CHECK(cells[0].refine == "none");
  CHECK(cells[1].refine == "ml");
  const fs::path dir = RunInTemp(c, "sweep-refine");
  const Table t = ReadTable(dir / "trials.csv");

  const Model model = c.models[0].Build(Registry());
  Vec x0(2);
  x0 << 20.0, 0.0;
  const Crlb direct =
      ComputeCrlb(model, x0, SampleGrid{3.0, 1e-3}, Vec::Constant(2, 0.2), Unknowns::Of(model));
  REQUIRE(direct.ok());
  long paired = 0;
  for (long trial = 0; trial < c.trials; ++trial) {
    for (long cell : {0L, 2L}) {
      const long none = cell * c.trials + trial, ml = (cell + 1) * c.trials + trial;
      REQUIRE(t.At(none, "status") == "ok");
      REQUIRE(t.At(ml, "status") == "ok");
      CHECK(t.At(none, "refine") == "none");
      CHECK(t.At(none, "refine_status").empty());
      CHECK(t.At(ml, "refine") == "ml");
      CHECK_FALSE(t.At(ml, "refine_status").empty());
      if (t.At(ml, "refine_status") == "ok") {
        CHECK(std::stod(t.At(ml, "e_alpha")) < std::stod(t.At(none, "e_alpha")));
        ++paired;
      }
      // Same bound in both cells of one σ; at σ = 0.2 the direct computation, at 0.05 a quarter of it.
      CHECK(t.At(ml, "crlb_e_alpha") == t.At(none, "crlb_e_alpha"));
      const double scale = cell == 0 ? 0.25 : 1.0;
      CHECK(std::stod(t.At(none, "crlb_e_alpha")) == Approx(scale * direct.mean_e_alpha).epsilon(1e-9));
      CHECK(std::stod(t.At(none, "crlb_e_beta")) == Approx(scale * direct.mean_e_beta).epsilon(1e-9));
    }
  }
  CHECK(paired >= 4);  // most fits are ok on 3 s of the §5 system

  const Table s = ReadTable(dir / "summary.csv");  // keyed by its first column, the cell
  for (long cell = 0; cell < 4; ++cell) {
    const double eff = std::stod(s.At(cell, "efficiency_alpha"));
    CHECK(eff == Approx(std::stod(s.At(cell, "e_alpha_mean")) / std::stod(s.At(cell, "crlb_e_alpha"))));
    CHECK(s.At(cell, "refine") == (cell % 2 == 0 ? "none" : "ml"));
  }
}

namespace {

// The Wilson score interval of p observed in n trials at z = 1.96, in closed form (intervals.hpp).
std::array<double, 2> Wilson(double p, double n) {
  const double z = 1.959963984540054, c = (p + z * z / (2 * n)) / (1 + z * z / n);
  const double h = z * std::sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n);
  return {c - h, c + h};
}

}  // namespace

TEST_CASE("sweep: per-trial standard errors, coverage of the 95 % intervals and its Wilson interval",
          "[sweep][refine]") {
  const SweepConfig c = ParseSweepText(kSweep, "refine.toml", Registry());
  const fs::path dir = RunInTemp(c, "sweep-coverage");
  const Table t = ReadTable(dir / "trials.csv");
  const Table s = ReadTable(dir / "summary.csv");
  const std::map<std::string, double> truth{{"a", 5.0}, {"b", 0.1}, {"lambda", 0.99}, {"mu", 0.0}};
  for (long cell = 0; cell < 4; ++cell) {
    for (const auto& [name, value] : truth) {
      const std::string hat = (name == "a" || name == "b" ? "alpha_hat_" : "beta_hat_") + name;
      long n = 0, covered = 0;
      for (long trial = 0; trial < c.trials; ++trial) {
        const long unit = cell * c.trials + trial;
        INFO("unit " << unit << " " << name << " " << t.At(unit, "message"));
        if (t.At(unit, "refine") == "none" || t.At(unit, "status") != "ok") {
          CHECK(t.At(unit, "se_" + name).empty());
          CHECK(t.At(unit, "cover_" + name).empty());
          continue;
        }
        const double se = std::stod(t.At(unit, "se_" + name));
        REQUIRE(se > 0);
        const bool in = std::abs(std::stod(t.At(unit, hat)) - value) <= 1.959963984540054 * se;
        CHECK(t.At(unit, "cover_" + name) == (in ? "1" : "0"));
        ++n;
        covered += in ? 1 : 0;
      }
      CHECK(std::stol(s.At(cell, "cover_" + name + "_n")) == n);
      if (n == 0) {
        CHECK(s.At(cell, "cover_" + name + "_mean").empty());
        continue;
      }
      const double p = double(covered) / double(n);
      const std::array<double, 2> w = Wilson(p, double(n));
      CHECK(std::stod(s.At(cell, "cover_" + name + "_mean")) == Approx(p).epsilon(1e-15));
      CHECK(std::stod(s.At(cell, "cover_" + name + "_ci95_lo")) == Approx(w[0]).epsilon(1e-12).margin(1e-15));
      CHECK(std::stod(s.At(cell, "cover_" + name + "_ci95_hi")) == Approx(w[1]).epsilon(1e-12));
      CHECK(w[0] < p);  // 3 of 3 covered still has an interval reaching below 1
    }
  }
  // Every estimate of this sweep used every sample: the bound over them is the whole record's.
  for (const auto& [unit, row] : t.rows) {
    if (t.At(unit, "status") != "ok") continue;
    CHECK(t.At(unit, "samples_used") == t.At(unit, "samples"));
    CHECK(t.At(unit, "crlb_fit_e_alpha") == t.At(unit, "crlb_e_alpha"));
    CHECK(t.At(unit, "crlb_fit_e_beta") == t.At(unit, "crlb_e_beta"));
  }
}

TEST_CASE("sweep: the bound over the samples a fit used is the bound computed over them", "[sweep][refine]") {
  // The drag ball nears its Zeno time in 5 s: the labelled routes leave out the bounces closer than 50
  // samples; multiple shooting by time fits them (measured: all 750 samples in both trials).
  const std::string text = ExampleSweep("drag-ball/drag-ball.toml", "x0 = [2.0, 0.0]\nt_end = 5.0",
                                        1.0 / 150.0, 1);
  const SweepConfig c = ParseSweepText(text, "drag.toml", Registry());
  const fs::path dir = RunInTemp(c, "sweep-drag-cut");
  const Table t = ReadTable(dir / "trials.csv");
  const Model model = c.models[0].Build(Registry());
  Vec x0(2);
  x0 << 2.0, 0.0;
  double sum_alpha = 0, sum_beta = 0, sum_e_alpha = 0;
  for (long trial = 0; trial < 2; ++trial) {
    INFO(t.At(trial, "message"));
    REQUIRE(t.At(trial, "status") == "ok");
    const long used = std::stol(t.At(trial, "samples_used"));
    REQUIRE(used <= std::stol(t.At(trial, "samples")));
    // The bound over samples 0 … used − 1, directly: height only, σ = 1e-3.
    const double dt = std::stod(t.At(trial, "dt"));  // the sweep's δt as written (ExampleSweep's 6 decimals)
    const Crlb direct = ComputeCrlb(model, x0, SampleGrid{(double(used) - 0.5) * dt, dt},
                                    Vec::Constant(1, 1e-3), Unknowns::Of(model), {}, {0});
    REQUIRE(direct.ok());
    REQUIRE(direct.samples == used);
    CHECK(std::stod(t.At(trial, "crlb_fit_e_alpha")) == Approx(direct.mean_e_alpha).epsilon(1e-9));
    CHECK(std::stod(t.At(trial, "crlb_fit_e_beta")) == Approx(direct.mean_e_beta).epsilon(1e-9));
    CHECK(std::stod(t.At(trial, "crlb_fit_e_beta")) >= std::stod(t.At(trial, "crlb_e_beta")) * (1 - 1e-9));
    sum_alpha += std::stod(t.At(trial, "crlb_fit_e_alpha"));
    sum_beta += std::stod(t.At(trial, "crlb_fit_e_beta"));
    sum_e_alpha += std::stod(t.At(trial, "e_alpha"));
  }
  const Table s = ReadTable(dir / "summary.csv");
  CHECK(std::stod(s.At(0, "crlb_fit_e_alpha")) == Approx(sum_alpha / 2).epsilon(1e-12));
  CHECK(std::stod(s.At(0, "crlb_fit_e_beta")) == Approx(sum_beta / 2).epsilon(1e-12));
  CHECK(std::stod(s.At(0, "efficiency_fit_alpha")) == Approx(sum_e_alpha / sum_alpha).epsilon(1e-12));
}

TEST_CASE("sweep: a refined unit's recursive pass is its recursive cell's, as a refined sweep alone has it",
          "[sweep][refine]") {
  // Two estimators: each refined unit follows its own recursive one on the same samples and reuses
  // that identification; its row is the one a sweep of the refined cells alone (each identified
  // afresh) writes.
  std::string text = kSweep;
  text.replace(text.find("estimator = \"rls\""), 17, "estimator = [\"rls\", \"gtls\"]");
  const SweepConfig both = ParseSweepText(text, "both.toml", Registry());
  text.replace(text.find("refine = [\"none\", \"ml\"]"), 23, "refine = [\"ml\", \"none\"]");
  const SweepConfig ml_first = ParseSweepText(text, "ml_first.toml", Registry());
  REQUIRE(EnumerateCells(both).size() == 8u);
  const Table t = ReadTable(RunInTemp(both, "sweep-refine-both") / "trials.csv");
  const Table u = ReadTable(RunInTemp(ml_first, "sweep-refine-ml-first") / "trials.csv");
  long compared = 0;
  for (long cell = 0; cell < 8; cell += 2) {
    for (long trial = 0; trial < both.trials; ++trial) {
      const long none = cell * both.trials + trial, ml = (cell + 1) * both.trials + trial;
      // ml_first: the same cells with refine swapped, so the refined unit comes first and runs fresh.
      const long fresh = cell * both.trials + trial;
      REQUIRE(t.At(ml, "refine") == "ml");
      REQUIRE(u.At(fresh, "refine") == "ml");
      for (const char* name : {"jumps_detected", "tp", "fp", "fn", "flow_status", "jump_status"}) {
        CHECK(t.At(ml, name) == t.At(none, name));
      }
      for (std::size_t c = 0; c < t.header.size(); ++c) {
        if (t.header[c] == "unit" || t.header[c] == "cell") continue;
        CHECK(t.rows.at(ml)[c] == u.rows.at(fresh)[c]);
        ++compared;
      }
    }
  }
  CHECK(compared > 100);
}

TEST_CASE("sweep: a trial whose refinement failed is a failure of its cell, never averaged",
          "[sweep][refine]") {
  // At σ = 8 and 15 on 3 s of the §5 system several refinements fail (missed jumps, Zeno fits,
  // residual correlation): 3 of the 8.
  std::string text = kSweep;
  text.replace(text.find("[0.05, 0.2]"), 11, "[8.0, 15.0]");
  text.replace(text.find("trials = 3"), 10, "trials = 4");
  const SweepConfig c = ParseSweepText(text, "failing.toml", Registry());
  const fs::path dir = RunInTemp(c, "sweep-refine-fail");
  const Table t = ReadTable(dir / "trials.csv");
  const Table s = ReadTable(dir / "summary.csv");
  long failed_total = 0;
  for (long cell = 0; cell < 4; ++cell) {
    long failed = 0, ok = 0;
    double sum = 0.0;
    for (long trial = 0; trial < c.trials; ++trial) {
      const long unit = cell * c.trials + trial;
      const std::string& refine = t.At(unit, "refine_status");
      if (t.At(unit, "refine") == "none" || refine == "ok") {
        CHECK(t.At(unit, "status") == "ok");
        sum += std::stod(t.At(unit, "e_alpha"));
        ++ok;
        continue;
      }
      ++failed;
      REQUIRE_FALSE(refine.empty());
      CHECK(t.At(unit, "status") == "refine_failed");
      CHECK(t.At(unit, "message").find("refinement " + refine) == 0);
      CHECK(t.At(unit, "e_alpha").empty());
      CHECK_FALSE(t.At(unit, "alpha_hat_a").empty());  // the recursive estimate it kept
    }
    CHECK(std::stol(s.At(cell, "failures")) == failed);
    if (ok > 0) CHECK(std::stod(s.At(cell, "e_alpha_mean")) == Approx(sum / double(ok)).epsilon(1e-12));
    if (ok == 0) CHECK(s.At(cell, "e_alpha_mean").empty());
    failed_total += failed;
  }
  CHECK(failed_total >= 3);
}

TEST_CASE("sweep: without a refine axis the tables keep their columns", "[sweep][refine]") {
  std::string text = kSweep;
  text.erase(text.find("refine = "), std::string("refine = [\"none\", \"ml\"]\n").size());
  const SweepConfig c = ParseSweepText(text, "plain.toml", Registry());
  CHECK_FALSE(c.grid.refine_axis);
  CHECK(EnumerateCells(c).size() == 2u);
  CHECK_FALSE(c.ToJson()["grid"].contains("refine"));
  CHECK_THROWS_WITH(
      ParseSweepText(std::string(kSweep).replace(std::string(kSweep).find("\"ml\""), 4, "\"map\""),
                     "bad.toml", Registry()),
      Catch::Contains("grid.refine") && Catch::Contains("unknown refinement 'map' (known: none, ml)"));
}

TEST_CASE("sweep: unknown guard parameters add γ columns, other sweeps' tables are unchanged", "[sweep][refine]") {
  const SweepConfig plain = ParseSweepText(kSweep, "refine.toml", Registry());
  std::vector<Model> plain_models;
  for (const auto& m : plain.models) plain_models.push_back(m.Build(Registry()));
  const std::vector<std::string> plain_header = TrialHeader(plain, plain_models);
  // (nor a model that is not an automaton the event columns)
  for (const char* name : {"e_gamma", "crlb_e_gamma", "events_true", "event_time_error"}) {
    CHECK(std::find(plain_header.begin(), plain_header.end(), name) == plain_header.end());
  }
  // The wall example, truth w = 1 (the file's w = 0.9), 6 s.
  const std::string text = ExampleSweep("wall/wall.toml", "params = { w = 1.0 }\nt_end = 6.0", 5e-4, 3);
  const SweepConfig c = ParseSweepText(text, "wall.toml", Registry());
  const fs::path dir = RunInTemp(c, "sweep-wall");
  const Table t = ReadTable(dir / "trials.csv");
  const Model model = c.models[0].Build(Registry());
  REQUIRE(model.gamma()[0] == 1.0);
  const Crlb direct = ComputeCrlb(model, DefaultState(model), SampleGrid{6.0, 5e-4}, Vec::Constant(2, 1e-3),
                                  Unknowns::Of(model));
  REQUIRE(direct.ok());
  for (long trial = 0; trial < 2; ++trial) {
    INFO(t.At(trial, "message"));
    REQUIRE(t.At(trial, "status") == "ok");
    const double w_hat = std::stod(t.At(trial, "gamma_hat_w"));
    CHECK(std::stod(t.At(trial, "rel_err_w")) == Approx(std::abs(w_hat - 1.0)).margin(1e-15));
    CHECK(std::stod(t.At(trial, "e_gamma")) == Approx(std::abs(w_hat - 1.0)).margin(1e-15));
    CHECK(std::abs(w_hat - 1.0) < 4 * std::stod(t.At(trial, "crlb_e_gamma")));
    CHECK(std::stod(t.At(trial, "crlb_e_gamma")) == Approx(direct.mean_e_gamma).epsilon(1e-9));  // direct: at σ
  }
  const Table s = ReadTable(dir / "summary.csv");
  CHECK(std::stod(s.At(0, "efficiency_gamma")) ==
        Approx(std::stod(s.At(0, "e_gamma_mean")) / std::stod(s.At(0, "crlb_e_gamma"))));
}

TEST_CASE("sweep of a hybrid automaton: events against the truth, each map's β error and bound",
          "[sweep][refine][automaton]") {
  // The floor-ceiling ball (two maps; 5 s, 10 impacts): every impact assigned to its wall.
  const std::string text = ExampleSweep("floor-ceiling/model.toml", "", 1e-3, 5);
  const SweepConfig c = ParseSweepText(text, "floor-ceiling.toml", Registry());
  const fs::path dir = RunInTemp(c, "sweep-floor-ceiling");
  const Table t = ReadTable(dir / "trials.csv");
  const Model model = c.models[0].Build(Registry());
  const Unknowns unknowns = Unknowns::Of(model);
  const Crlb direct = ComputeCrlb(model, DefaultState(model), SampleGrid{5.0, 1e-3}, Vec::Constant(2, 1e-3), unknowns);
  REQUIRE(direct.ok());
  const std::vector<double> per_map = MeanEBetaPerMap(model.spec(), unknowns, direct);
  REQUIRE(per_map.size() == 2);
  for (long trial = 0; trial < 2; ++trial) {
    INFO(t.At(trial, "message"));
    REQUIRE(t.At(trial, "status") == "ok");
    CHECK(t.At(trial, "events_true") == "10");
    CHECK(t.At(trial, "events_right") == "10");
    for (const char* name : {"events_wrong_map", "events_missed", "events_spurious"}) CHECK(t.At(trial, name) == "0");
    CHECK(std::stod(t.At(trial, "event_time_error")) < 1.0);  // a jump's detected time is the sample after it
    const double floor = std::stod(t.At(trial, "beta_hat_e_floor"));
    const double ceiling = std::stod(t.At(trial, "beta_hat_e_ceiling"));
    CHECK(std::stod(t.At(trial, "e_beta_floor")) == Approx(std::abs(floor - 0.9)).margin(1e-15));
    CHECK(std::stod(t.At(trial, "e_beta_ceiling")) == Approx(std::abs(ceiling - 0.7)).margin(1e-15));
    CHECK(std::stod(t.At(trial, "crlb_e_beta_floor")) == Approx(per_map[0]).epsilon(1e-9));  // direct: at σ
    CHECK(std::stod(t.At(trial, "crlb_e_beta_ceiling")) == Approx(per_map[1]).epsilon(1e-9));
    CHECK(std::abs(ceiling - 0.7) < 4 * per_map[1]);
  }
  const Table s = ReadTable(dir / "summary.csv");
  CHECK(s.At(0, "events_missed_mean") == "0");
  CHECK(std::stod(s.At(0, "e_beta_floor_mean")) ==
        Approx((std::stod(t.At(0, "e_beta_floor")) + std::stod(t.At(1, "e_beta_floor"))) / 2));
}
