// The refinement's shared Ceres options (sim/refine/solver.hpp).
#include "sim/refine/solver.hpp"

#include <glog/logging.h>

namespace hysid {

ceres::Solver::Options LevenbergMarquardt(const RefineOptions& options) {
  static const bool quiet = [] {  // Ceres reports a failed evaluation through glog as well
    FLAGS_minloglevel = google::GLOG_FATAL;
    return true;
  }();
  (void)quiet;
  ceres::Solver::Options so;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = options.function_tolerance;
  so.parameter_tolerance = options.parameter_tolerance;
  so.gradient_tolerance = 1e-16;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  so.num_threads = 1;
  return so;
}

}  // namespace hysid
