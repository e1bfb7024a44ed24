// A missed small final impact: models/wall-msd.toml (a spring–mass hitting a wall at x = 1, its
// impacts shrinking to a last one at 0.3 m/s) with its defaults and σ = 0.2 on both states, as
// `hysid simulate --model-file models/wall-msd.toml --sigma 0.2 --seed S` and `hysid identify` with
// the defaults give it. The residual detector finds the first two of the three impacts in every seed
// 1–30; the refinement mends the third from the fitted model, checked by the data (measured: all 30
// ok on all samples within 2.7 CRLB sd, 29 by "1 added, 0 dropped", seed 28 by multiple shooting).
// Three of the seeds where it did not: 9 and 14 ended in jump-count-mismatch (the fit distorted by
// the missed impact moved its first jump 19 samples off, so the mended labels moved with it), 19 was
// ok only on the samples before the third impact.
#include <catch2/catch.hpp>

#include "core/identify/identifier.hpp"
#include "core/model_file/model_file.hpp"
#include "sim/measurement.hpp"
#include "sim/refine/refine.hpp"

namespace hysid {
namespace {

struct WallRun {
  Model model = ReadModelFile(HYSID_MODELS_DIR "/wall-msd.toml").model;
  SampleGrid grid{model.spec().default_t_end, model.spec().default_dt};
  Vec x0 = Eigen::Map<const Vec>(model.spec().default_x0.data(), 2);
  Vec sigma = Vec::Constant(2, 0.2);
  Trajectory truth = Simulate(model, x0, grid);
};

TEST_CASE("wall-msd at σ = 0.2: the missed final impact mended, ok on all samples within 4 CRLB sd",
          "[refine]") {
  const WallRun run;
  REQUIRE(run.truth.jumps.size() == 3);
  const Unknowns unknowns = Unknowns::Of(run.model);
  const Crlb bound = ComputeCrlb(run.model, run.x0, run.grid, run.sigma, unknowns);
  REQUIRE(bound.ok());
  const Vec true_theta = HybridParameters::Of(run.model, run.x0).Theta(unknowns);
  IdentifierSettings settings;
  settings.detector.kind = DetectorKind::kResidual;
  settings.data_rtol = settings.data_atol = 1e-12;
  settings.sigma = run.sigma;
  RefineOptions options;
  options.sigma = run.sigma;
  for (const std::uint64_t seed : {9, 14, 19}) {
    const Mat y = AddMeasurementNoise(run.truth.x, run.sigma, NoiseKey{.seed = seed, .stream = 0});
    const IdentifyResult recursive = Identify(run.model, y, run.grid.dt, settings);
    const RefineResult r = RefineIdentification(run.model, run.truth.t, y, {}, RefinementStart(recursive), options);
    INFO("seed " << seed << ": detected " << recursive.jumps_detected << ", " << ToString(r.status) << " "
                 << r.reason << "; mended: " << r.mended);
    CHECK(recursive.jumps_detected == 2);
    REQUIRE(r.ok());
    CHECK(r.samples_used == static_cast<long>(run.truth.t.size()));
    CHECK(r.model_jumps == 3);
    const double worst = ((r.estimate.Theta(unknowns) - true_theta).array().abs() / bound.sd.array()).maxCoeff();
    INFO("worst error " << worst << " CRLB sd");
    CHECK(worst < 4.0);
  }
}

}  // namespace
}  // namespace hysid
