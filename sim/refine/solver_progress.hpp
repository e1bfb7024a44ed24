// Watching the refinement's solver (progress on a terminal): while a ScopedSolverProgress lives on a
// thread, every Levenberg–Marquardt iteration of the refinement's fits on that thread
// (sim/refine/solver.hpp) calls its callback with the fit (counted from 1 over the solves it saw), the
// iteration (0: the start) and the cost ½ Σ (r/σ)². Nested scopes: the innermost is called.
#pragma once

#include <functional>

namespace hysid {

class ScopedSolverProgress {
 public:
  using Callback = std::function<void(int fit, int iteration, double cost)>;
  explicit ScopedSolverProgress(Callback callback);
  ~ScopedSolverProgress();
  ScopedSolverProgress(const ScopedSolverProgress&) = delete;
  ScopedSolverProgress& operator=(const ScopedSolverProgress&) = delete;

  // Called by the solver (sim/refine/solver.cpp).
  void Iteration(int iteration, double cost);
  // The scope watching this thread, or null.
  static ScopedSolverProgress* current();

 private:
  Callback callback_;
  ScopedSolverProgress* previous_;
  int fits_ = 0;
};

}  // namespace hysid
