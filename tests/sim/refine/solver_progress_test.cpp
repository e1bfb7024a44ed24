// The refinement's solver iterations seen by a ScopedSolverProgress (sim/refine/solver_progress.hpp):
// each fit numbered from 1 at its iteration 0, the iterations of a fit counted from 0 one by one, every
// cost finite, the last one the refinement's final cost (to 1e-6); nothing seen outside the scope.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "core/builtin/impact_msd.hpp"
#include "sim/measurement.hpp"
#include "sim/refine/refine.hpp"
#include "sim/refine/solver_progress.hpp"

namespace hysid {
namespace {

struct Seen {
  int fit, iteration;
  double cost;
};

TEST_CASE("the refinement's iterations reach a ScopedSolverProgress on the calling thread", "[refine]") {
  const Model model{ImpactMsd{}};
  const SampleGrid grid{5.0, 5e-4};
  const Trajectory truth = Simulate(model, (Vec(2) << 20.0, 0.0).finished(), grid);
  const Mat y = AddMeasurementNoise(truth.x, Vec::Constant(2, 0.01), NoiseKey{.seed = 3, .stream = 0});
  std::vector<std::uint8_t> gamma(truth.j.size(), 0);
  for (std::size_t k = 1; k < truth.j.size(); ++k) gamma[k] = truth.j[k] != truth.j[k - 1];
  const Vec alpha0 = model.alpha(), beta0 = model.beta();
  const std::vector<RefineChain> chains{RefineChain::Uniform(y, grid.dt, gamma)};
  std::vector<Seen> seen;
  RefineResult r;
  {
    const ScopedSolverProgress watch([&](int fit, int iteration, double cost) { seen.push_back({fit, iteration, cost}); });
    CHECK(ScopedSolverProgress::current() == &watch);
    r = Refine(model, chains, alpha0, beta0);
  }
  CHECK(ScopedSolverProgress::current() == nullptr);
  REQUIRE(r.ok());
  REQUIRE(!seen.empty());
  CHECK(seen.front().fit == 1);
  CHECK(seen.front().iteration == 0);
  for (std::size_t i = 1; i < seen.size(); ++i) {
    CAPTURE(i, seen[i].fit, seen[i].iteration, seen[i].cost);
    CHECK(std::isfinite(seen[i].cost));
    if (seen[i].iteration == 0) {
      CHECK(seen[i].fit == seen[i - 1].fit + 1);
    } else {
      CHECK(seen[i].fit == seen[i - 1].fit);
      CHECK(seen[i].iteration == seen[i - 1].iteration + 1);
    }
  }
  CHECK(seen.back().cost == Approx(r.final_cost).epsilon(1e-6));  // re-evaluated at the fit: 1.5e-7 apart measured
  const std::size_t before = seen.size();
  (void)Refine(model, chains, alpha0, beta0);  // no scope: nothing more seen
  CHECK(seen.size() == before);
}

}  // namespace
}  // namespace hysid
