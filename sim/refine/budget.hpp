// The CVODE step and jump budget of every run a fit evaluates (sim/refine/fit.cpp, time_shooting.cpp),
// and of the recursive estimate's run beside a fit (sim/events/fitted_outputs.cpp). Internal to sim/.
#pragma once

#include <algorithm>

#include "sim/sensitivity/sensitivity.hpp"

namespace hysid {

inline constexpr long kStepGrowth = 10;
inline constexpr long kStepFloor = 1000;

// A run's budget over `samples` samples, for every run a fit evaluates: a model that jumps more often
// than its samples, or steps hundreds of times per sample, chatters there (a ball coming to rest) or
// is stiff at that point, and cannot be read on the samples: the run stops there (a failed
// evaluation, which Ceres rejects as a step) instead of taking seconds. `last_steps`: the CVODE steps
// of the last run of the same samples that completed (0: none yet); a trial point whose run needs
// more than kStepGrowth times as many (plus a floor of kStepFloor) left the region where the fit has
// been: it fails there too, as Ceres' step into it is rejected either way.
inline void BudgetRun(SensitivityOptions& o, long samples, long last_steps = 0) {
  o.sim.max_jumps = static_cast<int>(std::min<long>(o.sim.max_jumps, 2 * samples + 10));
  o.sim.max_steps = std::min(o.sim.max_steps, 200 * samples + 1000);
  if (last_steps > 0) o.sim.max_steps = std::min(o.sim.max_steps, kStepGrowth * last_steps + kStepFloor);
}

}  // namespace hysid
