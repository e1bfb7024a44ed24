// The Ceres options every fit of the refinement shares (sim/refine/fit.cpp, time_shooting.cpp).
// Internal to sim/refine.
#pragma once

#include <ceres/solver.h>

#include "sim/refine/refine.hpp"

namespace hysid {

// Levenberg–Marquardt with RefineOptions' iteration budget and tolerances, one thread, and Ceres'
// own logging silenced (glog's threshold raised once per process: a fit's outcome is its status);
// with a ScopedSolverProgress on this thread (sim/refine/solver_progress.hpp), each iteration is
// handed to it.
ceres::Solver::Options LevenbergMarquardt(const RefineOptions& options);

}  // namespace hysid
