// Identification from the height alone (examples/drag-ball): the velocity reconstructed as a start
// (core/identify/reconstruct.hpp), the recursive estimate from it, and the refinement on the measured
// row only, against the bound of height-only samples (estimators.md §8).
#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <sstream>

#include "core/identify/identifier.hpp"
#include "core/identify/reconstruct.hpp"
#include "core/model_file/model_file.hpp"
#include "sim/measurement.hpp"
#include "sim/refine/refine.hpp"

namespace hysid {
namespace {

Model DragBall() {
  std::ifstream in(std::string(HYSID_EXAMPLES_DIR) + "/drag-ball/drag-ball.toml");
  std::stringstream text;
  text << in.rdbuf();
  return ParseModelFile(text.str(), "drag-ball.toml").model;
}

struct HeightOnly {
  Model model = DragBall();
  SampleGrid grid{5.0, 1.0 / 150.0};
  Vec x0 = (Vec(2) << 2.0, 0.0).finished();
  Trajectory truth = Simulate(model, x0, grid);
  // The height with 1 mm noise (draw `draw` of seed 26).
  Mat Height(std::uint64_t draw) const {
    const Mat y = AddMeasurementNoise(truth.x, (Vec(2) << 1e-3, 0.0).finished(), NoiseKey{.seed = 26, .stream = draw});
    return y.topRows(1);
  }
};

// The pipeline of `hysid identify` on a model measured in part: reconstruct, identify with the
// detected kinks as labels, refine on the measured row.
RefineResult IdentifyHeightOnly(const HeightOnly& run, const Mat& h, Reconstruction* rec) {
  *rec = ReconstructStates(PlanReconstruction(run.model, {0}), run.truth.t, h, {}, Vec());
  IdentifyOptions io;
  io.labels = rec->gamma;
  const IdentifyResult recursive = Identify(run.model, rec->x, run.grid.dt, IdentifierSettings{}, io);
  RefineOptions options;
  options.measured = {0};
  return RefineIdentification(run.model, run.truth.t, rec->x, {}, recursive, options);
}

TEST_CASE("height only: g, k and e within 3 SE, SE within 20 % of the bound's sd, in several seeds",
          "[refine][measured]") {
  const HeightOnly run;
  REQUIRE(run.truth.status.completed());
  const HybridParameters truth = HybridParameters::Of(run.model, run.x0);
  for (std::uint64_t draw = 0; draw < 4; ++draw) {
    Reconstruction rec;
    const RefineResult r = IdentifyHeightOnly(run, run.Height(draw), &rec);
    INFO("draw " << draw << ": " << ToString(r.status) << " " << r.reason << "; samples fit " << r.samples_used
                 << ", detected " << r.detected_jumps);
    REQUIRE(r.ok());
    CHECK(r.sigma[1] == 0.0);  // v is not measured
    CHECK(r.sigma[0] == Approx(1e-3).epsilon(0.1));
    const SampleGrid fitted{static_cast<double>(r.samples_used - 1) * run.grid.dt, run.grid.dt};
    const Crlb bound = ComputeCrlb(run.model, run.x0, fitted, (Vec(1) << 1e-3).finished(), r.unknowns, {}, {0});
    REQUIRE(bound.ok());
    const Vec error = r.estimate.Theta(r.unknowns) - truth.Theta(r.unknowns);
    for (std::size_t i = 0; i < r.names.size(); ++i) {
      const auto ii = static_cast<Eigen::Index>(i);
      INFO(r.names[i] << ": error " << error[ii] << ", se " << r.standard_errors[ii] << ", CRLB sd " << bound.sd[ii]);
      CHECK(std::abs(error[ii]) < 3.0 * r.standard_errors[ii]);
      CHECK(r.standard_errors[ii] == Approx(bound.sd[ii]).epsilon(0.2));
    }
  }
}

TEST_CASE("height only: the refinement never uses the reconstructed row as data", "[refine][measured]") {
  const HeightOnly run;
  Reconstruction rec;
  const Mat h = run.Height(0);
  const RefineResult r = IdentifyHeightOnly(run, h, &rec);
  REQUIRE(r.ok());
  // The same fit with the reconstruction's v row replaced by nonsense (only its first sample, the
  // start of v0, kept): the same estimate.
  IdentifyOptions io;
  io.labels = rec.gamma;
  const IdentifyResult recursive = Identify(run.model, rec.x, run.grid.dt, IdentifierSettings{}, io);
  Mat scrambled = rec.x;
  for (Eigen::Index k = 1; k < scrambled.cols(); ++k) scrambled(1, k) = 100.0 * std::sin(double(k));
  RefineOptions options;
  options.measured = {0};
  options.routes = RefineRoutesWithout({RefineRoute::kRepairedStart, RefineRoute::kGrownSpan});  // (the repaired start reads every row)
  const RefineResult a = RefineIdentification(run.model, run.truth.t, rec.x, {}, recursive, options);
  const RefineResult b = RefineIdentification(run.model, run.truth.t, scrambled, {}, recursive, options);
  REQUIRE(a.ok());
  REQUIRE(b.ok());
  CHECK((a.estimate.Theta(a.unknowns) - b.estimate.Theta(b.unknowns)).cwiseAbs().maxCoeff() <
        1e-3 * a.standard_errors.minCoeff());
}

TEST_CASE("height only, x0 known (all, or v0 alone): held, and the bound without them", "[refine][measured]") {
  const HeightOnly run;
  const Mat h = run.Height(1);
  Reconstruction rec = ReconstructStates(PlanReconstruction(run.model, {0}), run.truth.t, h, {}, Vec());
  IdentifyOptions io;
  io.labels = rec.gamma;
  const IdentifyResult recursive = Identify(run.model, rec.x, run.grid.dt, IdentifierSettings{}, io);
  for (const std::vector<int>& known : {std::vector<int>{0, 1}, std::vector<int>{1}}) {
    RefineOptions options;
    options.measured = {0};
    options.x0_known = known;
    options.x0 = run.x0;
    const RefineResult r = RefineIdentification(run.model, run.truth.t, rec.x, {}, recursive, options);
    INFO(known.size() << " known: " << r.reason);
    REQUIRE(r.ok());
    const SampleGrid fitted{static_cast<double>(r.samples_used - 1) * run.grid.dt, run.grid.dt};
    const Crlb all = ComputeCrlb(run.model, run.x0, fitted, (Vec(1) << 1e-3).finished(), r.unknowns, {}, {0});
    std::vector<int> held;
    for (const int i : known) held.push_back(3 + i);  // θ = (g, k, e, h0, v0)
    const Crlb bound = CrlbFromFisher(all.fisher, r.unknowns, all.names, held);
    REQUIRE(bound.ok());
    for (const int i : known) {
      CHECK(r.estimate.x0[i] == run.x0[i]);
      CHECK(r.standard_errors[3 + i] == 0.0);
    }
    for (int i = 0; i < 5; ++i) {
      if (bound.sd[i] == 0.0) continue;
      INFO(r.names[static_cast<std::size_t>(i)]);
      CHECK(r.standard_errors[i] == Approx(bound.sd[i]).epsilon(0.2));
    }
    if (known.size() == 2) {  // equal to the bound computed without x0 at all
      const Crlb without = ComputeCrlb(run.model, run.x0, fitted, (Vec(1) << 1e-3).finished(),
                                       Unknowns::Of(run.model, false), {}, {0});
      CHECK(bound.sd.head(3).isApprox(without.sd, 1e-6));
    }
  }
}

TEST_CASE("a state acting on nothing measured: singular Fisher information naming it", "[refine][measured]") {
  // The velocity alone, before the first bounce: v(t) does not depend on h0 in free flight, so x0[h]
  // is not identifiable, and the bound says so by name.
  const HeightOnly run;
  const Crlb bound = ComputeCrlb(run.model, run.x0, SampleGrid{0.3, 1.0 / 150.0}, (Vec(1) << 1e-3).finished(),
                                 Unknowns::Of(run.model), {}, {1});
  REQUIRE(bound.status == CrlbStatus::kSingular);
  CHECK_THAT(bound.message, Catch::Contains("direction 1 x0[h]"));
  // Height only, over a span with a bounce (e acts through it): identifiable.
  CHECK(ComputeCrlb(run.model, run.x0, SampleGrid{1.5, 1.0 / 150.0}, (Vec(1) << 1e-3).finished(),
                    Unknowns::Of(run.model), {}, {0})
            .ok());
}

}  // namespace
}  // namespace hysid
