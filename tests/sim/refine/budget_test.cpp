// A fit's run budget (BudgetRun, sim/refine/budget.hpp): the absolute caps over N samples (2N + 10
// jumps, 200N + 1 000 steps), and the cap relative to the last completed run of the same samples
// (kStepGrowth times its steps plus kStepFloor): a run that needs more stops at exactly that many
// steps, not completed, and one that needs fewer is the same run bit for bit as without the cap.
#include <catch2/catch.hpp>

#include "core/builtin/impact_msd.hpp"
#include "sim/refine/budget.hpp"
#include "sim/sensitivity/sensitivity.hpp"

namespace hysid {
namespace {

TEST_CASE("a fit's runs stop at their step budget, relative to the last completed run", "[refine]") {
  SensitivityOptions o;
  BudgetRun(o, 50);
  CHECK(o.sim.max_jumps == 110);
  CHECK(o.sim.max_steps == 11000);
  SensitivityOptions capped;
  BudgetRun(capped, 50, 300);
  CHECK(capped.sim.max_jumps == 110);
  CHECK(capped.sim.max_steps == kStepGrowth * 300 + kStepFloor);
  SensitivityOptions loose;
  BudgetRun(loose, 50, 100000);  // the absolute cap is the smaller
  CHECK(loose.sim.max_steps == 11000);

  const Model model{ImpactMsd{}};
  const HybridParameters at = HybridParameters::Of(model, (Vec(2) << 20.0, 0.0).finished());
  const SampleGrid grid{40.0, 0.1};
  SensitivityOptions whole;
  BudgetRun(whole, 401);
  const SensitivityTrajectory full = SimulateSensitivities(model, at, Unknowns::Of(model), grid, whole);
  REQUIRE(full.ok());
  const long steps = full.trajectory.stats.steps;
  CAPTURE(steps);
  REQUIRE(steps > 2 * kStepFloor);

  // The last completed run needed a twentieth of these steps: this one is cut at 10× that + 1 000.
  const long last = (steps - kStepFloor) / 20;
  SensitivityOptions cut;
  BudgetRun(cut, 401, last);
  REQUIRE(cut.sim.max_steps < steps);
  const SensitivityTrajectory stopped = SimulateSensitivities(model, at, Unknowns::Of(model), grid, cut);
  CHECK_FALSE(stopped.ok());
  CHECK(stopped.trajectory.stats.steps == cut.sim.max_steps);
  CHECK(stopped.trajectory.status.t_reached < grid.t_end);

  // Within the cap: the same run, bit for bit.
  SensitivityOptions room;
  BudgetRun(room, 401, steps / kStepGrowth + 1);
  REQUIRE(room.sim.max_steps >= steps);
  const SensitivityTrajectory same = SimulateSensitivities(model, at, Unknowns::Of(model), grid, room);
  REQUIRE(same.ok());
  CHECK(same.trajectory.stats.steps == steps);
  CHECK(same.trajectory.x == full.trajectory.x);
  CHECK(same.sensitivities == full.sensitivities);
}

}  // namespace
}  // namespace hysid
