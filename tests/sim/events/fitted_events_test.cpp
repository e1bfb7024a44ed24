// The example automata (examples/floor-ceiling, examples/pump-tank) through identify's pipeline
// (the recursive pass with its events assigned, the refinement from it): the fitted model's event
// times (sim/events) against the simulator's located events, and the refined standard errors against
// the Cramér–Rao bound at the truth, over seeds 1–3 at 1 % of each example's level range.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include <fmt/format.h>

#include "core/identify/identifier.hpp"
#include "core/model/automaton.hpp"
#include "core/model_file/model_file.hpp"
#include "sim/events/fitted_events.hpp"
#include "sim/measurement.hpp"
#include "sim/refine/refine.hpp"
#include "sim/sensitivity/crlb.hpp"

namespace hysid {
namespace {

struct Example {
  Model model;
  SampleGrid grid;
  Vec x0;
  Trajectory truth;
  explicit Example(const std::string& name)
      : model(ReadModelFile(std::string(HYSID_EXAMPLES_DIR) + "/" + name + "/model.toml").model),
        grid{model.spec().default_t_end, model.spec().default_dt},
        x0(DefaultState(model)),
        truth(Simulate(model, x0, grid)) {}
};

struct Fit {
  IdentifyResult recursive;
  RefineResult refined;
  FittedEvents events;
};

Fit IdentifyAndRefine(const Example& e, double sigma, std::uint64_t seed) {
  const Mat y = AddMeasurementNoise(e.truth.x, Vec::Constant(e.model.state_size(), sigma), NoiseKey{.seed = seed});
  Fit f;
  IdentifierSettings settings;  // hysid identify's defaults: rls and the residual detector
  settings.detector.kind = DetectorKind::kResidual;
  f.recursive = Identify(e.model, y, e.grid.dt, settings, IdentifyOptions{});
  f.refined = RefineIdentification(e.model, e.truth.t, y, {}, RefinementStart(f.recursive));
  f.events = FitEventTimes(e.model, e.truth.t, y, {}, Mat(), f.recursive, f.refined);
  return f;
}

// Every located event of the truth has a fitted one of its map within one sample, and within 5 of
// its standard errors; the fitted crossings pair one to one with the detected events.
void CheckEventTimes(const Example& e, const Fit& f, double* largest) {
  REQUIRE(f.events.reason.empty());
  REQUIRE(f.events.crossings.size() == e.truth.jumps.size());
  REQUIRE(f.recursive.events.size() == e.truth.jumps.size());
  for (std::size_t i = 0; i < e.truth.jumps.size(); ++i) {
    const JumpRecord& jump = e.truth.jumps[i];
    CAPTURE(i, jump.t, f.events.time[i], f.events.se[i]);
    CHECK(f.recursive.events[i].map == jump.map);
    CHECK(f.events.crossings[i].map == jump.map);
    CHECK(f.events.crossings[i].time == f.events.time[i]);
    const double error = std::abs(f.events.time[i] - jump.t);
    CHECK(error < e.grid.dt);
    REQUIRE(std::isfinite(f.events.se[i]));
    CHECK(f.events.se[i] > 0.0);
    CHECK(error < 5.0 * f.events.se[i]);
    *largest = std::max(*largest, error / e.grid.dt);
  }
}

// Each refined standard error within 20 % of the CRLB's sd at the truth (σ the data's).
void CheckStandardErrors(const Example& e, const Fit& f, double sigma, double* low, double* high) {
  const Crlb bound =
      ComputeCrlb(e.model, e.x0, e.grid, Vec::Constant(e.model.state_size(), sigma), Unknowns::Of(e.model));
  REQUIRE(bound.ok());
  REQUIRE(f.refined.standard_errors.size() == bound.sd.size());
  for (Eigen::Index i = 0; i < bound.sd.size(); ++i) {
    const double ratio = f.refined.standard_errors[i] / bound.sd[i];
    CAPTURE(f.refined.names[std::size_t(i)], ratio);
    CHECK(ratio > 0.8);
    CHECK(ratio < 1.2);
    *low = std::min(*low, ratio);
    *high = std::max(*high, ratio);
  }
}

void CheckExample(const std::string& name, double sigma) {
  const Example e(name);
  REQUIRE(e.truth.status.completed());
  double largest = 0.0, low = std::numeric_limits<double>::infinity(), high = 0.0;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    CAPTURE(name, seed);
    const Fit f = IdentifyAndRefine(e, sigma, seed);
    CAPTURE(f.refined.reason);
    REQUIRE(f.refined.ok());
    CheckEventTimes(e, f, &largest);
    CheckStandardErrors(e, f, sigma, &low, &high);
  }
  std::printf("%s at sigma %g, seeds 1-3: largest fitted event-time error %.3f samples; se / CRLB sd in [%.3f, %.3f]\n",
              name.c_str(), sigma, largest, low, high);
}

TEST_CASE("floor-ceiling: fitted impact times within a sample, standard errors at the bound", "[events]") {
  CheckExample("floor-ceiling", 2e-2);
}

TEST_CASE("pump-tank: fitted switch times within a sample, standard errors at the bound", "[events]") {
  CheckExample("pump-tank", 1e-2);
}

// The detector's events thinned (every other one dropped, as a detector that misses events) and one
// given the wrong map: each kept event still gets the crossing of its own true event, the mislabelled
// one none, with the reason naming its sample.
TEST_CASE("events the detector missed or mislabelled: each kept event beside its own crossing", "[events]") {
  const Example e("pump-tank");
  const Fit f = IdentifyAndRefine(e, 1e-2, 1);
  REQUIRE(f.refined.ok());
  REQUIRE(f.recursive.events.size() == e.truth.jumps.size());
  REQUIRE(e.truth.jumps.size() >= 6);
  IdentifyResult thinned = f.recursive;
  thinned.events.clear();
  std::vector<std::size_t> truth_of;  // per kept event: its true event
  for (std::size_t i = 1; i < f.recursive.events.size(); i += 2) {
    thinned.events.push_back(f.recursive.events[i]);
    truth_of.push_back(i);
  }
  const std::size_t wrong = 1;
  const int maps = static_cast<int>(JumpMaps(e.model.spec()).size());
  REQUIRE(maps >= 2);
  thinned.events[wrong].map = (thinned.events[wrong].map + 1) % maps;
  const FittedEvents fe = FitEventTimes(e.model, e.truth.t, e.truth.x, {}, Mat(), thinned, f.refined);
  REQUIRE(fe.crossings.size() == e.truth.jumps.size());
  for (std::size_t k = 0; k < thinned.events.size(); ++k) {
    CAPTURE(k, thinned.events[k].sample);
    if (k == wrong) {
      CHECK(std::isnan(fe.time[k]));
      continue;
    }
    CHECK(fe.time[k] == fe.crossings[truth_of[k]].time);
    CHECK(std::abs(fe.time[k] - e.truth.jumps[truth_of[k]].t) < e.grid.dt);
  }
  CHECK(fe.reason.find(fmt::format("sample {}", thinned.events[wrong].sample)) != std::string::npos);
}

TEST_CASE("a refinement that is not ok gives no event times, and says why", "[events]") {
  const Example e("pump-tank");
  Fit f = IdentifyAndRefine(e, 1e-2, 1);
  f.refined.status = RefineStatus::kNotConverged;
  const FittedEvents none = FitEventTimes(e.model, e.truth.t, e.truth.x, {}, Mat(), f.recursive, f.refined);
  REQUIRE(none.time.size() == f.recursive.events.size());
  for (double t : none.time) CHECK(std::isnan(t));
  CHECK(none.crossings.empty());
  CHECK(none.reason.find("not-converged") != std::string::npos);
}

}  // namespace
}  // namespace hysid
