// The refinement's shared Ceres options (sim/refine/solver.hpp).
#include "sim/refine/solver.hpp"

#include <algorithm>

#include <glog/logging.h>

#include "sim/refine/solver_progress.hpp"

namespace hysid {
namespace {

thread_local ScopedSolverProgress* watching = nullptr;

// Hands each iteration to the thread's ScopedSolverProgress (one per thread; it outlives every solve).
class ForwardIteration final : public ceres::IterationCallback {
 public:
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (watching != nullptr) watching->Iteration(s.iteration, s.cost);
    return ceres::SOLVER_CONTINUE;
  }
};
thread_local ForwardIteration forward;

}  // namespace

ScopedSolverProgress::ScopedSolverProgress(Callback callback)
    : callback_(std::move(callback)), previous_(watching) {
  watching = this;
}

ScopedSolverProgress::~ScopedSolverProgress() { watching = previous_; }

void ScopedSolverProgress::Iteration(int iteration, double cost) {
  if (iteration == 0) ++fits_;
  if (callback_) callback_(fits_, iteration, cost);
}

ScopedSolverProgress* ScopedSolverProgress::current() { return watching; }

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
  if (watching != nullptr) so.callbacks.push_back(&forward);
  return so;
}

}  // namespace hysid
