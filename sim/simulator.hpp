// Hybrid simulator on SUNDIALS CVODE with exact jump location.
//
// System:   ξ' = φ(ξ)α on C, ξ+ = ψ(ξ)β on D (a hysid::Model with its true α, β; γ and the inputs
//           u(t) from an Exogenous, sim/exogenous.hpp).
// Method:   the hybrid run loop (sim/hybrid_run.hpp, shared with the sensitivities) with no payload:
//           CVODE Adams–Moulton with fixed-point iteration; CVODE's root finding, filtered by each
//           guard's crossing direction, locates the crossings to solver precision; the state is put
//           on the guard, the jump map applied (again while ξ+ ∈ D), and CVODE re-initialised. Jumps
//           have priority when ξ ∈ C ∩ D (HyEQ rule 1).
// Samples:  t_k = k·δt for k = 0..K, K = ⌊t_end/δt⌋, read from CVODE's interpolating polynomial
//           (dense output). A sample at or after a jump's time is post-jump: hybrid time (t_k, j_k)
//           with j_k the number of jumps at times ≤ t_k.
// Outcome:  a SimStatus value; the simulator never throws for a numerical outcome.
#pragma once

#include <atomic>
#include <string>
#include <vector>

#include "core/model/model.hpp"
#include "sim/exogenous.hpp"

namespace hysid {

struct SampleGrid {
  double t_end = 20.0;  // last sample time is ⌊t_end/δt⌋·δt
  double dt = 5e-4;     // δt
  // Number of samples, K + 1.
  long size() const;
  bool IsValid(std::string* error) const;
};

// `count` ≥ 2 samples evenly over [0, t_end]: δt = t_end/(count − 1), lowered by the ulps that keep
// the last sample (count − 1)·δt from passing t_end (an input given up to t_end covers the run).
SampleGrid EvenGrid(double t_end, long count);

struct SimOptions {
  double rtol = 1e-12;       // CVODE relative tolerance
  double atol = 1e-12;       // CVODE absolute tolerance (every component)
  long max_steps = 2000000;  // internal CVODE steps over the whole run
  int max_jumps = 100000;    // jump budget
  // Zeno: the run stops when the interval between consecutive jumps has shrunk for
  // zeno_window jumps in a row (each below (1 − 1e-3) times the one before: constant intervals
  // are no accumulation) and fallen below zeno_interval (seconds). 1e-5 s keeps the last
  // bounces of a ball well above atol (peak height g·Δ²/8 ≈ 1.2e-10 at Δ = 1e-5).
  double zeno_interval = 1e-5;
  int zeno_window = 3;
  // A chain of jumps at one instant (ξ+ ∈ D again) longer than this is Zeno at that instant.
  int max_jumps_at_one_time = 100;
  // Measured inputs: CVODE stops at an input sample only where u has a kink there, a slope change
  // above input_kink times the input's median |slope| (InputKinkTimes); elsewhere its error control
  // steps across the samples (x is C¹ across them). 0: a stop at every input sample.
  double input_kink = 0.1;
  // Raised (by another thread: Ctrl-C in the Python module): the run stops before its next CVODE step
  // (status kSolverFailure, "stopped"). Null: never.
  const std::atomic<bool>* stop = nullptr;
  // A second such flag, raised when the run's result is no longer needed (a later start of a search
  // whose earlier start has ended it, sim/refine): either flag stops the run.
  const std::atomic<bool>* cancel = nullptr;
  bool stopped() const { return (stop != nullptr && stop->load()) || (cancel != nullptr && cancel->load()); }
  // Field-naming message "SimOptions::rtol = -1. Violated constraint: rtol > 0".
  bool IsValid(std::string* error) const;
};

enum class SimStop {
  kCompleted,      // reached the last sample time
  kZeno,           // jumps accumulate; zeno_time estimates the accumulation time
  kJumpBudget,     // max_jumps reached without accumulating
  kSolverFailure,  // CVODE returned an error flag, or the step budget ran out
  kNonFinite,      // the state became NaN or infinite
  kLeftDomain,     // the state left C ∪ D without a located crossing
};

const char* ToString(SimStop stop);

struct SimStatus {
  SimStop stop = SimStop::kCompleted;
  double t_reached = 0.0;  // time the trajectory is valid up to
  double zeno_time = 0.0;  // estimated accumulation time when stop == kZeno
  std::string message;
  bool completed() const { return stop == SimStop::kCompleted; }
};

struct JumpRecord {
  int j = 0;       // jump counter after the jump (1 for the first jump)
  double t = 0.0;  // jump time
  int guard = -1;  // guard that fired (-1: initial state or chained jump inside D)
  Vec pre;         // ξ(t, j − 1), on the guard
  Vec post;        // ξ(t, j) = ψ(pre)β
  int map = 0;     // the jump map applied (core/model/automaton.hpp; 0 for the paper's class)
  int mode = 0;    // the mode q after the jump
};

struct SolverStats {
  long steps = 0;
  long rhs_evals = 0;
  long root_evals = 0;
};

struct Trajectory {
  double dt = 0.0;
  std::vector<double> t;  // sample times kδt (only those reached)
  std::vector<int> j;     // jump counter at each sample
  std::vector<int> q;     // mode at each sample (empty for a one-mode model)
  Mat x;                  // n × samples, true state
  std::vector<JumpRecord> jumps;
  SimStatus status;
  SolverStats stats;
  long size() const { return static_cast<long>(t.size()); }
};

// Throws std::invalid_argument for a bad grid, bad options, x0 of the wrong size or not finite, or
// guard parameters or inputs that do not fit the model or the grid (ExogenousError); every numerical
// outcome is reported in Trajectory::status.
Trajectory Simulate(const Model& model, const Vec& x0, const SampleGrid& grid, const SimOptions& options = {},
                    const Exogenous& exo = {});

}  // namespace hysid
