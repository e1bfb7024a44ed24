// A ball bouncing on a vertically oscillating table (examples/oscillating-table/model.toml: time a
// third state, guard x − s(τ), v⁺ = ṡ(τ) − e(v − ṡ(τ))), 28 impacts in 14 s, measured at about 1 %
// of each state's range. One shooting from the first sample cannot follow the whole run (its jump
// check fails); multiple shooting, chosen automatically, reaches the single-shooting fit at the
// bound.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "core/identify/identifier.hpp"
#include "core/model_file/model_file.hpp"
#include "sim/measurement.hpp"
#include "sim/refine/refine.hpp"

namespace hysid {
namespace {

struct OscillatingTable {
  Model model = ReadModelFile(HYSID_EXAMPLES_DIR "/oscillating-table/model.toml").model;
  SampleGrid grid{model.spec().default_t_end, model.spec().default_dt};
  Vec x0 = DefaultState(model);
  Vec sigma = (Vec(3) << 0.01, 0.08, 0.001).finished();
  Trajectory truth = Simulate(model, x0, grid);
  IdentifyResult Recursive(const Mat& y) const {
    IdentifierSettings settings;  // as hysid identify: the residual detector, the solver's accuracy
    settings.detector.kind = DetectorKind::kResidual;
    settings.data_rtol = settings.data_atol = 1e-12;
    return Identify(model, y, grid.dt, settings);
  }
};

// Every unknown of the fit against the truth, in CRLB sd.
void CheckAtTheBound(const OscillatingTable& run, const RefineResult& r, const Crlb& bound) {
  const Vec error = r.estimate.Theta(r.unknowns) - HybridParameters::Of(run.model, run.x0).Theta(r.unknowns);
  for (Eigen::Index i = 0; i < error.size(); ++i) {
    INFO(r.names[static_cast<std::size_t>(i)] << ": error " << error[i] << ", crlb sd " << bound.sd[i]);
    CHECK(std::abs(error[i]) < 4 * bound.sd[i]);
  }
}

// Measured (seeds 1–3): one shooting from the recursive start is ok only on the first 2417 samples
// (seed 1; its span retries cut it before a jump its model misplaces); with the defaults the grown
// span reaches all 14 001, within 1.35 CRLB sd; without the grown span and the span retries, multiple
// shooting (14 segments) does in seed 1 (not in seeds 2 and 3).
TEST_CASE("oscillating table: the defaults fit all samples within 4 CRLB sd", "[refine]") {
  const OscillatingTable run;
  REQUIRE(run.truth.status.completed());
  REQUIRE(run.truth.jumps.size() == 28);
  const Crlb bound = ComputeCrlb(run.model, run.x0, run.grid, run.sigma, Unknowns::Of(run.model));
  REQUIRE(bound.ok());
  for (std::uint64_t seed : {1, 2, 3}) {
    const Mat y = AddMeasurementNoise(run.truth.x, run.sigma, NoiseKey{.seed = seed, .stream = 0});
    const RefineResult r = RefineIdentification(run.model, run.truth.t, y, {}, RefinementStart(run.Recursive(y)));
    INFO("seed " << seed << ": " << r.reason << " (" << r.mended << ")");
    REQUIRE(r.ok());
    CHECK(r.samples_used == run.grid.size());
    CHECK(r.model_jumps == 28);
    CheckAtTheBound(run, r, bound);
  }
}

TEST_CASE("oscillating table: one shooting alone fits a cut span, multiple shooting all samples at the bound",
          "[refine]") {
  const OscillatingTable run;
  const Crlb bound = ComputeCrlb(run.model, run.x0, run.grid, run.sigma, Unknowns::Of(run.model));
  REQUIRE(bound.ok());
  const Mat y = AddMeasurementNoise(run.truth.x, run.sigma, NoiseKey{.seed = 1, .stream = 0});
  const IdentifyResult recursive = RefinementStart(run.Recursive(y));
  RefineOptions options;
  options.routes = RefineRoutesWithout({RefineRoute::kGrownSpan, RefineRoute::kSegmentShooting, RefineRoute::kTimeShooting});
  const RefineResult single = RefineIdentification(run.model, run.truth.t, y, {}, recursive, options);
  INFO(single.reason << "; " << single.span_reason);
  CHECK((!single.ok() || single.samples_used < run.grid.size()));
  options.routes = RefineRoutesWithout({RefineRoute::kGrownSpan, RefineRoute::kTimeShooting});
  options.max_span_retries = 0;  // (multiple shooting is not tried for a fit ok on cut spans)
  const RefineResult shot = RefineIdentification(run.model, run.truth.t, y, {}, recursive, options);
  INFO(shot.reason);
  REQUIRE(shot.ok());
  CHECK_THAT(shot.mended, Catch::StartsWith("multiple shooting over"));
  CHECK(shot.route == "multiple shooting");  // the route whose fit won
  CHECK(shot.samples_used == run.grid.size());
  CHECK(shot.model_jumps == 28);
  CheckAtTheBound(run, shot, bound);
  options.shooting_jumps = 0;
  std::string error;
  CHECK_FALSE(options.IsValid(&error));
  CHECK(error == "RefineOptions::shooting_jumps = 0: must be >= 1");
  options.shooting_jumps = 2;
  REQUIRE(options.IsValid(&error));
  options.routes = {RefineRoute::kLabels, RefineRoute::kTimeShooting, RefineRoute::kGrownSpan};
  CHECK_FALSE(options.IsValid(&error));
  CHECK(error == "RefineOptions::routes: 'grown from a short span' out of order or repeated: the routes are tried "
                 "in AllRefineRoutes' order, each once");
  options.routes = {RefineRoute::kTimeShooting};
  CHECK_FALSE(options.IsValid(&error));
  CHECK(error == "RefineOptions::routes: must begin with 'single shooting on the detected labels'");
  CHECK(RefineRoutesWithout({RefineRoute::kLabels, RefineRoute::kGrownSpan}) ==
        std::vector<RefineRoute>{RefineRoute::kLabels, RefineRoute::kRepairedStart, RefineRoute::kSegmentShooting,
                                 RefineRoute::kTimeShooting});
}

}  // namespace
}  // namespace hysid
