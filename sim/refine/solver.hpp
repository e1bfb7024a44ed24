// The Ceres options every fit of the refinement shares (sim/refine/fit.cpp, time_shooting.cpp).
// Internal to sim/refine.
#pragma once

#include <ceres/solver.h>

#include "sim/refine/refine.hpp"
#include "sim/sensitivity/sensitivity.hpp"

namespace hysid {

// Levenberg–Marquardt with RefineOptions' iteration budget and tolerances, one thread, and Ceres'
// own logging silenced (glog's threshold raised once per process: a fit's outcome is its status);
// with a ScopedSolverProgress on this thread (sim/refine/solver_progress.hpp), each iteration is
// handed to it.
ceres::Solver::Options LevenbergMarquardt(const RefineOptions& options);

// A run's budget over `samples` samples, for every run a fit evaluates: a model that jumps more often
// than its samples, or steps hundreds of times per sample, chatters there (a ball coming to rest) or
// is stiff at that point, and cannot be read on the samples: the run stops there (a failed
// evaluation, which Ceres rejects as a step) instead of taking seconds.
void BudgetRun(SensitivityOptions& o, long samples);

}  // namespace hysid
