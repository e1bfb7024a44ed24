// The one hybrid run loop: CVODE set-up, guard crossings (root finding filtered by each guard's
// direction), the chain of jumps at one instant, the Zeno rule and the jump and step budgets, dense
// output at the sample times, and the status. Internal to sim/: Simulate runs it alone;
// the sensitivities (sim/sensitivity/) run it with a Payload, integrated with the state.
//
// Flow:     ξ' = φ_q(ξ)α in the current mode q (Context::mode; q0 from Exogenous::initial_mode, else
//           ModelSpec::default_mode), with the payload's own components, CVODE Adams–Moulton and
//           fixed-point iteration, one vector (ξ, then the payload's components), all in the error test.
// Guards:   only the guards armed in q (ArmedMap ≥ 0) are root functions; a guard not armed in q is
//           the constant 1 (it never changes sign, so CVODE never locates it; CVODE is re-initialised at
//           every jump anyway, so the set armed changes with no CVodeRootInit). CVODE sees a root
//           as a sign change between step ends, so with explicit maps no step is longer than the mean
//           sample interval: a guard crossed and crossed back within it (a ball grazing a ceiling
//           on a parabola that Adams integrates exactly, with huge steps) is otherwise missed.
// Jumps:    paper's class (no explicit maps): at a located crossing ξ is put on the guard and
//           ξ+ = ψ(ξ)β applied, again while ξ+ ∈ D (HyEQ rule 1: jumps have priority on C ∩ D).
//           Explicit maps (ModelSpec::jumps): the crossing applies the armed map m (Context::map = m,
//           its β slice; an identity map keeps ξ) and q ← ModeAfter(q, m). Several guards crossing at
//           one instant: the one whose map comes first in spec.jumps fires; the others, and every
//           guard armed in the new mode, are re-checked at ξ+ (ChainedCrossing): a guard past zero in
//           its direction, or at zero (within 1e-10·max(1, ‖ξ‖∞)) and moving in its direction under
//           the new mode's flow (its rate dh/dt = ∇h·f + ∂h/∂t: a guard in the inputs or t moves
//           with them), fires next at the same instant (each counts toward max_jumps_at_one_time).
//           A guard of direction "both" fires only where CVODE locates it. Then CVODE is
//           re-initialised.
// Zeno:     a chain of more than max_jumps_at_one_time jumps at one instant; or, after each crossing,
//           jump intervals below zeno_interval that shrank for zeno_window jumps in a row, each below
//           (1 − 1e-3) times the one before (constant intervals equal up to rounding, a stiff
//           spring's half-periods, are not an accumulation); the accumulation time is extrapolated
//           from the last two intervals as a geometric series. With explicit maps the intervals are
//           those of one guard's own jumps (per guard: a floor's bounces accumulate while a ceiling's
//           or a switch's jumps interleave with constant spacing).
// Samples:  state from CVODE's last step's polynomial (read from its Nordsieck array, the same bits as
//           CVodeGetDky, sim/nordsieck.hpp); the payload reads its own at the same times; the mode q
//           per sample in Trajectory::q when the model has several modes.
#pragma once

#include <string>
#include <vector>

#include <nvector/nvector_serial.h>

#include "core/model/model.hpp"
#include "sim/exogenous.hpp"
#include "sim/nordsieck.hpp"
#include "sim/simulator.hpp"
#include "sim/sundials_ptr.hpp"

namespace hysid::hybrid {

// Extra components integrated with the state and carried across the jumps (the sensitivities).
class Payload {
 public:
  virtual ~Payload() = default;
  // Number of extra components (stored after ξ in the integrated vector).
  virtual long size() const = 0;
  // Their time derivative at (ξ, extra) in the evaluation context of the time (u(t), γ); called inside
  // CVODE's right-hand side.
  virtual void Flow(const double* x, const double* extra, const Context& ctx, double* extra_dot) = 0;
  // At each (re)start of the integration from the current (t, x) in the current mode (ctx.t, ctx.mode):
  // the current values into extra[0..size).
  virtual void Restart(const Context& ctx, const Vec& x, double* extra) = 0;
  // After every solver step, at the time the step returned (a root's time at a root return).
  virtual void Returned(double t, const double* x, const double* extra) = 0;
  // At a root return: the values returned become the current ones (just before the jump).
  virtual void AdoptReturned() = 0;
  // Before the jumps at one instant ctx.t in mode ctx.mode, ξ on guard `guard` (−1: a jump whose time
  // does not move with θ: the initial state in D or past a guard, or a chained crossing past zero);
  // false with *why when the jump rule cannot be applied (the run stops as a solver failure). With
  // explicit maps each crossing of a chain is its own BeginJumps … EndJumps. `projected` ≥ 0: a
  // crossing past zero whose state x was put on that guard (its projection) before the jump, so
  // that the jump reads the projected state whatever the state before.
  virtual bool BeginJumps(const Context& ctx, int guard, const Vec& x, std::string* why, int projected = -1) = 0;
  // Each jump of the chain, from the pre-jump state; ctx.mode the mode before it, ctx.map its map.
  virtual void Jump(const Vec& pre, const Context& ctx) = 0;
  // After the chain, at the post-jump state in the mode after it (ctx.mode); the current values hold
  // from there.
  virtual void EndJumps(const Vec& post, const Context& ctx) = 0;
  // Sample k at time t within the last step; x its state (n), as the trajectory records it.
  virtual void Sample(long k, double t, const double* x) = 0;
  // Sample k at the current values (no step taken since them); x its state.
  virtual void SampleCurrent(long k, const double* x) = 0;
};

// Where the samples are: k·δt, or times[k] when given.
struct SampleTimes {
  long count = 0;
  double dt = 0.0;
  const std::vector<double>* times = nullptr;
  double at(long k) const {
    return times ? (*times)[static_cast<std::size_t>(k)] : static_cast<double>(k) * dt;
  }
};

// What CVODE's callbacks see.
struct CallbackData {
  const Model* model = nullptr;
  const Vec* alpha = nullptr;
  Payload* payload = nullptr;
  ContextSource* context = nullptr;
  long n = 0;
  int guard_count = 0;
  const std::vector<char>* armed = nullptr;  // per guard, armed in the current mode; nullptr: all
  bool nonfinite_rhs = false;
  std::string last_error;  // CVODE's last error message, for the status
};

// How a run emits its samples: in increasing order (the plain loop), or in any order (each once).
enum class SampleOrder { kIncreasing, kAny };

// One run. Run() is the plain loop (sample k on the segment the model is in at t_k); the primitives
// below it let a caller drive other sample orders (the matched sensitivities) under the same rules.
class Engine {
 public:
  // `exo` (γ, inputs) must outlive the engine and fit the model (ExogenousError).
  Engine(const Model& model, const Vec& alpha, const Vec& beta, const Exogenous& exo, const SampleTimes& samples,
         const SimOptions& options, Payload* payload, SampleOrder order = SampleOrder::kIncreasing);
  Engine(const Engine&) = delete;
  Engine& operator=(const Engine&) = delete;

  // The plain loop from x0 to the last sample time, or to the stop.
  Trajectory Run(const Vec& x0);

  // ---- primitives (each false after recording the stop in the status) ----
  // Creates CVODE at (0, x0); then, when x0 ∈ D, the jumps of rule 1 (no Zeno-interval check).
  bool Setup(const Vec& x0);
  // (Re)starts the integration at (t(), x()) towards tstop (either direction), guards on or off.
  bool Start(double tstop, bool roots);
  bool DisableRoots();
  // One internal step towards tstop: the flag (CV_SUCCESS, CV_ROOT_RETURN, CV_TSTOP_RETURN at tstop) or −1
  // when stopped. With inputs, no step crosses a kink of the interpolated u (an input sample where
  // the slope changes by more than SimOptions::input_kink times its median: CVODE stops there and
  // goes on, CV_SUCCESS); other input samples are crossed under CVODE's error control.
  int Step(double tstop, double* tret);
  // The evaluation context at time t (u(t), γ, the current mode); valid until the next call.
  Context ContextAt(double t) { return context_.At(t); }
  // Samples begin..end−1, all within the last step, on segment `segment` (kIncreasing: begin is
  // the number emitted so far; kAny: each sample once, ranges in any order, forward or backward).
  void EmitStep(long begin, long end, int segment);
  // Samples begin..end−1 at the current state (no step taken since it), as EmitStep.
  void EmitCurrent(long begin, long end, int segment);
  // At a root return at tret: the returned state and payload become current; the guard that fired
  // (with explicit maps, of several at once the one whose map comes first in spec.jumps).
  int AdoptRoot(double tret);
  // The jumps at t() from x() (put on `guard` first), then the Zeno rule and the jump budget.
  bool Jumps(int guard);
  // Records the stop (at t()) and its message; always false.
  bool Fail(SimStop stop, std::string message);
  // Records the run as completed to the last sample time.
  void Complete();
  // The trajectory: samples up to the first one not emitted, jumps, status, counters.
  Trajectory Finish();

  double t() const { return t_; }
  const Vec& x() const { return x_; }
  int jumps() const { return static_cast<int>(out_.jumps.size()); }
  int mode() const { return mode_; }
  double t_last() const { return t_last_; }
  const SampleTimes& samples() const { return samples_; }
  // The state returned by the last step.
  Eigen::Map<const Vec> returned() const { return {N_VGetArrayPointer_Serial(y_.get()), n_}; }

 private:
  bool JumpChain(int guard);
  bool MapChain(int guard, bool located);
  double MeanSampleInterval() const;
  double NextInputStop(double t, double limit) const;
  int ChainedCrossing(bool* at_zero);
  void SetMode(int mode);
  bool CheckZenoAndBudget();
  bool CheckZeno(int guard);
  void Mark(long begin, long end, int segment);
  void TaylorCoefficients(int q, double tn, double h, bool direct);
  void EmitHorner(int q, double tn, double h, long begin, long end);
  bool Check(int flag, const char* function);
  void AccumulateCounters();

  const Model& model_;
  const Vec& alpha_;
  const Vec& beta_;
  SampleTimes samples_;
  SimOptions options_;
  Payload* payload_;
  SampleOrder order_;
  ContextSource context_;
  bool explicit_maps_ = false;  // spec.jumps given: maps, modes and the armed-guard chain rule
  bool several_modes_ = false;  // Trajectory::q is filled
  int mode_ = 0;                // the current mode q
  std::vector<char> armed_;     // per guard, armed in mode_ (explicit maps)
  std::vector<double> input_stops_;  // the input kinks CVODE stops at (InputKinkTimes), increasing
  double stop_set_ = 0.0;            // the stop time CVODE holds (with input stops)
  double last_tret_ = 0.0;           // the time the last step returned (with input stops)
  long n_ = 0;
  double t_last_ = 0.0;
  double t_ = 0.0;
  Vec x_;
  bool at_init_ = true;  // CVODE holds (0, x0) from CVodeInit: the first Start needs no CVodeReInit
  bool roots_ = false;
  std::vector<char> filled_;  // SampleOrder::kAny: which samples were emitted
  Mat coefficients_;
  nordsieck::History history_;
  long steps_ = 0, rhs_evals_ = 0, root_evals_ = 0;
  CallbackData data_;
  Trajectory out_;
  // Declared in creation order; destroyed in reverse.
  sundials_ptr::ContextPtr ctx_;
  sundials_ptr::NVectorPtr y_;
  sundials_ptr::NVectorPtr scratch_;
  sundials_ptr::NonlinearSolverPtr nls_;
  sundials_ptr::CvodePtr cvode_;
};

}  // namespace hysid::hybrid
