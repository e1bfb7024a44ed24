// Owning handles for the SUNDIALS objects of one integration (context, vectors, nonlinear solver,
// CVODES memory), each freed by its own SUNDIALS call; declare them in creation order so they are
// freed in reverse. Also the guard direction in CVODE's convention and the guard a root return
// found. Internal to sim/: the hybrid run loop (sim/hybrid_run.hpp) uses them.
#pragma once

#include <memory>
#include <type_traits>
#include <vector>

#include <cvodes/cvodes.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sundials/sundials_nonlinearsolver.h>

#include "core/model/model.hpp"

namespace hysid::sundials_ptr {

struct ContextDeleter {
  void operator()(SUNContext ctx) const { SUNContext_Free(&ctx); }
};
struct NVectorDeleter {
  void operator()(N_Vector v) const { N_VDestroy(v); }
};
struct NonlinearSolverDeleter {
  void operator()(SUNNonlinearSolver s) const { SUNNonlinSolFree(s); }
};
struct CvodeDeleter {
  void operator()(void* mem) const { CVodeFree(&mem); }
};
using ContextPtr = std::unique_ptr<std::remove_pointer_t<SUNContext>, ContextDeleter>;
using NVectorPtr = std::unique_ptr<std::remove_pointer_t<N_Vector>, NVectorDeleter>;
using NonlinearSolverPtr = std::unique_ptr<std::remove_pointer_t<SUNNonlinearSolver>, NonlinearSolverDeleter>;
using CvodePtr = std::unique_ptr<void, CvodeDeleter>;

// CVodeSetRootDirection's value for a guard's crossing direction.
inline int ToCvodeDirection(Crossing c) {
  switch (c) {
    case Crossing::kFalling: return -1;
    case Crossing::kRising: return 1;
    case Crossing::kBoth: return 0;
  }
  return 0;
}

// The guard whose root CVODE returned (the first of several found at once); 0 if none.
inline int FiredGuard(void* cvode, int guard_count) {
  std::vector<int> found(static_cast<std::size_t>(guard_count), 0);
  CVodeGetRootInfo(cvode, found.data());
  for (std::size_t i = 0; i < found.size(); ++i) {
    if (found[i] != 0) return static_cast<int>(i);
  }
  return 0;
}

}  // namespace hysid::sundials_ptr
