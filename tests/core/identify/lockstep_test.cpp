// Identifications fed together (IdentifyLockstep) against each one alone (Identify): the same bits.
#include <catch2/catch.hpp>

#include <atomic>
#include <string>
#include <vector>

#include "core/builtin/impact_msd.hpp"
#include "core/identify/identifier.hpp"
#include "core/identify/lockstep.hpp"
#include "sim/measurement.hpp"
#include "sim/simulator.hpp"

namespace hysid {
namespace {

IdentifierSettings Paper(double r) {
  IdentifierSettings s;
  s.detector.r = r;
  s.detector.tau0 = 1e5;
  s.sets = false;
  return s;
}

IdentifierSettings Residual(double false_alarm) {
  IdentifierSettings s;
  s.detector.kind = DetectorKind::kResidual;
  s.detector.false_alarm = false_alarm;
  s.sets = false;
  return s;
}

void CheckSame(const IdentifyResult& together, const IdentifyResult& alone) {
  CHECK(together.gamma == alone.gamma);
  CHECK(together.statistic == alone.statistic);
  CHECK(together.threshold == alone.threshold);
  CHECK(together.alpha_hat == alone.alpha_hat);
  CHECK(together.beta_hat == alone.beta_hat);
  CHECK(together.jumps_detected == alone.jumps_detected);
  CHECK(together.flow_status == alone.flow_status);
  CHECK(together.jump_status == alone.jump_status);
  CHECK(together.flow_reason == alone.flow_reason);
  CHECK(together.jump_reason == alone.jump_reason);
  CHECK(together.flow_hull == alone.flow_hull);
  CHECK(together.jump_hull == alone.jump_hull);
  CHECK(together.stopped == alone.stopped);
}

struct Run {
  Model model{ImpactMsd{}};
  Trajectory truth;
  Run() : truth(Simulate(model, DefaultState(model), SampleGrid{20.0, 5e-4})) {}
};

// IdentifyLockstep of `settings` on y, each result against Identify alone, bit for bit; its counts.
LockstepCounts CheckEachAlone(const Run& run, const Mat& y, const std::vector<IdentifierSettings>& settings,
                              const IdentifyOptions& options) {
  LockstepCounts counts;
  const std::vector<IdentifyResult> together =
      IdentifyLockstep(run.model, y, run.truth.dt, settings, options, &counts);
  REQUIRE(together.size() == settings.size());
  for (std::size_t i = 0; i < settings.size(); ++i) {
    INFO("unit " << i);
    CheckSame(together[i], Identify(run.model, y, run.truth.dt, settings[i], options));
  }
  return counts;
}

}  // namespace

TEST_CASE("the §5 run noisy: M = 1 … 6 paper-detector units together give each unit's own result, bit for bit",
          "[identify][lockstep]") {
  const Run run;
  REQUIRE(run.truth.status.completed());
  const std::vector<double> rs{5.0, 20.0, 50.0, 220.0, 500.0, 1000.0};  // r = 5 flags most samples
  for (const double sigma : {0.0, 0.01, 0.25}) {
    const Mat y = AddMeasurementNoise(run.truth.x, Vec::Constant(2, sigma), NoiseKey{11, 0});
    std::vector<IdentifyResult> alone;
    for (const double r : rs) alone.push_back(Identify(run.model, y, run.truth.dt, Paper(r)));
    // At σ = 0.25, r = 5 flags most samples: a unit that leaves the lockstep at once, block after block.
    if (sigma == 0.25) CHECK(alone.front().jumps_detected > y.cols() / 2);
    CHECK(alone[3].jumps_detected >= 14);
    for (std::size_t m = 1; m <= rs.size(); ++m) {
      INFO("sigma " << sigma << ", " << m << " units");
      // Each M takes the units from the other end too, so that r = 5 runs beside others in one.
      const bool from_end = m % 2 == 0;
      std::vector<IdentifierSettings> settings;
      std::vector<const IdentifyResult*> expected;
      for (std::size_t i = 0; i < m; ++i) {
        const std::size_t at = from_end ? rs.size() - 1 - i : i;
        settings.push_back(Paper(rs[at]));
        expected.push_back(&alone[at]);
      }
      LockstepCounts counts;
      const std::vector<IdentifyResult> together =
          IdentifyLockstep(run.model, y, run.truth.dt, settings, IdentifyOptions{}, &counts);
      REQUIRE(together.size() == m);
      for (std::size_t i = 0; i < m; ++i) CheckSame(together[i], *expected[i]);
      CHECK(counts.total == static_cast<long>(m) * y.cols());
      if (m > 1) {
        CHECK(counts.lockstep > 0);  // the lockstep path was taken
      } else {
        CHECK(counts.lockstep == 0);  // one unit: Identify itself
      }
    }
  }
}

TEST_CASE("a trial's mix together: paper and residual detectors, sets, statistics off, more units than "
          "one lockstep holds",
          "[identify][lockstep]") {
  const Run run;
  const Mat y = AddMeasurementNoise(run.truth.x, Vec::Constant(2, 0.05), NoiseKey{12, 0});
  std::vector<IdentifierSettings> settings;
  for (const double r : {5.0, 20.0, 50.0, 220.0, 500.0, 1000.0}) settings.push_back(Paper(r));
  settings.push_back(Residual(1e-6));
  settings.push_back(Residual(1e-8));
  IdentifierSettings with_sets = Paper(220.0);
  with_sets.sets = true;  // fed alone every block
  settings.push_back(with_sets);
  for (const double r : {100.0, 300.0}) settings.push_back(Paper(r));  // 11 units: 8 + 2 in lockstep
  IdentifierSettings known = Residual(1e-8);
  known.sigma = Vec::Constant(2, 0.05);
  settings.push_back(known);
  for (const bool statistics : {true, false}) {
    INFO("statistics " << statistics);
    IdentifyOptions options;
    options.statistics = statistics;
    options.check_paper_bound = statistics;
    const FlowRows rows = BuildFlowRows(run.model, y, run.truth.dt);
    if (!statistics) options.flow_rows = &rows;  // the sweep's shared rows
    const LockstepCounts counts = CheckEachAlone(run, y, settings, options);
    // The 8 paper units without sets step in lockstep through most of their flow samples, or (statistics
    // off) follow a twin's identifier.
    CHECK(counts.lockstep + counts.shared > 8 * (y.cols() / 2));
    if (statistics) {
      CHECK(counts.shared == 0);  // twins only without statistics
    } else {
      CHECK(counts.shared > 0);
    }
  }
}

TEST_CASE("twins (statistics off): units that differ only in r or false_alarm, in any order, share an "
          "identifier until they differ and still give each unit's own result, bit for bit",
          "[identify][lockstep][twins]") {
  const Run run;
  std::vector<IdentifierSettings> settings;
  for (const double r : {500.0, 5.0, 1000.0, 20.0, 220.0, 50.0}) settings.push_back(Paper(r));
  for (const double p : {1e-8, 1e-3, 1e-6}) settings.push_back(Residual(p));  // 1e-3: false alarms
  IdentifierSettings other_tau0 = Paper(220.0);
  other_tau0.detector.tau0 = 1e4;  // not a twin of the others
  settings.push_back(other_tau0);
  IdentifierSettings forgetting = Residual(1e-8);
  forgetting.flow_estimator.forgetting = 0.9999;  // nor this
  settings.push_back(forgetting);
  const long followers_at_most = 5 + 2;  // the paper group and the residual group, each led by one
  for (const double sigma : {0.0, 0.01, 0.05, 0.25}) {
    INFO("sigma " << sigma);
    const Mat y = AddMeasurementNoise(run.truth.x, Vec::Constant(2, sigma), NoiseKey{14, 0});
    IdentifyOptions options;
    options.statistics = false;
    options.check_paper_bound = false;
    const LockstepCounts counts = CheckEachAlone(run, y, settings, options);
    CHECK(counts.shared > 0);
    CHECK(counts.shared < followers_at_most * y.cols());  // some left their leader
  }
}

TEST_CASE("lockstep: a stop flag raised before the call stops every unit, bad inputs throw as Identify does",
          "[identify][lockstep][stop]") {
  const Run run;
  const Mat y = AddMeasurementNoise(run.truth.x, Vec::Constant(2, 0.01), NoiseKey{13, 0});
  const std::vector<IdentifierSettings> settings{Paper(220.0), Paper(50.0), Residual(1e-8)};
  std::atomic<bool> stop{true};
  IdentifyOptions options;
  options.stop = &stop;
  const std::vector<IdentifyResult> stopped = IdentifyLockstep(run.model, y, run.truth.dt, settings, options);
  for (const IdentifyResult& r : stopped) {
    CHECK(r.stopped);
    CHECK(r.flow_status == EstimatorStatus::kNotExcited);
    CHECK(r.flow_reason == "stopped");
  }
  const FlowRows rows = BuildFlowRows(run.model, y, 2.0 * run.truth.dt);
  CHECK_THROWS_AS(IdentifyLockstep(run.model, y, run.truth.dt, settings, IdentifyOptions{.flow_rows = &rows}),
                  std::invalid_argument);
  CHECK_THROWS_AS(IdentifyLockstep(run.model, y.topRows(1), run.truth.dt, settings), std::invalid_argument);
}

}  // namespace hysid
