// The Ceres solve of the output-error refinements (Refine, RefineChains): Levenberg–Marquardt with
// RefineOptions' iteration budget and tolerances, one thread, Ceres' own logging silenced (the fit's
// status carries a failed evaluation). Internal to sim/refine.
#pragma once

#include <ceres/ceres.h>

#include "sim/refine/refine.hpp"

namespace hysid {

ceres::Solver::Summary SolveLeastSquares(ceres::Problem& problem, const RefineOptions& options,
                                         ceres::LinearSolverType linear_solver);

}  // namespace hysid
