// Forward sensitivities of a hybrid trajectory, S_k = ∂ξ(t_k)/∂θ, θ = (unknown α, unknown β, unknown γ,
// ξ0), γ the guard parameters; a model with inputs runs on a measured InputSignal u(t).
//
// Run:   the hybrid run loop of Simulate (sim/hybrid_run.hpp) with S as its payload: the same jump
//        chain, Zeno rule, budgets and status, so both stop alike.
// Flow:  S' = (∂f/∂ξ) S + ∂f/∂θ with f = φ(ξ)α (∂f/∂α_i = column i of φ; ∂f/∂γ_i by central
//        differences, zero unless φ uses γ), integrated with the state
//        as one vector (ξ, then S column-major) by CVODE (Adams, fixed-point corrector; S is in the
//        error test).
// Jump:  at a guard crossing h(ξ, t, u(t), α, β, γ) = 0 with flow f⁻ before, jump map g(ξ) = ψ(ξ)β,
//        flow f⁺ after:
//          ∂t_j/∂θ = −(∇ₓh·S⁻ + ∂h/∂θ)/(∇ₓh·f⁻ + ∂h/∂t)
//        (∂h/∂α, ∂h/∂β, ∂h/∂γ: Model::GuardParameterJacobian; ∂h/∂t with u(t) moving:
//        ContextSource::GuardTimeDerivative; the denominator is dh/dt along the flow)
//          S⁺ = (∂g/∂ξ)(S⁻ + f⁻ ∂t_j/∂θ) + ∂g/∂θ + (∂g/∂t − f⁺) ∂t_j/∂θ
//        (saltation; Hiskens & Pai 2000; ∂g/∂t ≠ 0 only for a ψ that reads the time or the inputs)
//        ∇h and ∂g/∂ξ by central differences of Model::Guards and Model::Jump (exact up to rounding
//        for guards and jump maps affine in ξ); ∂g/∂β_i = column i of ψ(ξ⁻). With unknown γ the
//        chain's first jump is g = ψ(P(ξ, γ))β, P the projection onto the guard that fired, and
//        ∂g/∂ξ, ∂g/∂γ are central differences of that (a wall x⁺ = w: ∂x⁺/∂w = 1). A chain of jumps
//        at one instant applies (∂g/∂ξ)(·) + ∂g/∂θ once per jump.
// Modes: plain (SimulateSensitivities): the loop's own run, sample k on the segment the model is in
//        at t_k, as Simulate (bit for bit in the states when sensitivities = false).
//        matched (SimulateSensitivitiesMatched): sample k on the segment given by the caller (the
//        detected jump count); each segment's flow is continued past the model's next jump and
//        integrated backward before its own start, so no sample changes segment as θ moves.
// The analytic S_k is the derivative at a fixed jump count: the information carried by the jump
// times themselves (a sample crossing a moving jump) is not in it.
#pragma once

#include <string>
#include <vector>

#include "core/model/model.hpp"
#include "sim/simulator.hpp"

namespace hysid {

// Which entries of θ = (α_u, β_u, γ_u, ξ0) are estimated (γ: the guard parameters).
struct Unknowns {
  std::vector<int> alpha;  // indices into α
  std::vector<int> beta;   // indices into β
  std::vector<int> gamma;  // indices into γ
  bool x0 = true;          // all n entries of ξ0
  // The entries not marked `known` in the model's spec, and ξ0 when `with_x0`.
  static Unknowns Of(const Model& model, bool with_x0 = true);
  // |α_u| + |β_u| + |γ_u|: the entries before ξ0.
  int shared() const { return static_cast<int>(alpha.size() + beta.size() + gamma.size()); }
  int size(int n) const { return shared() + (x0 ? n : 0); }
  // "a", "b", "lambda", "mu", "x0[x]", "x0[v]" for the §5 system.
  std::vector<std::string> Names(const Model& model) const;
  // The spec's entries of the shared part of θ, in θ's order (their bounds, names, descriptions).
  std::vector<const Parameter*> Parameters(const Model& model) const;
  // Field-naming message when an index is out of range or repeated.
  bool IsValid(const Model& model, std::string* error) const;
};

// Full parameter vectors (known entries included), the initial state, the guard parameters γ
// (empty: the model's own) and the initial mode q0 (−1: the model's default_mode; discrete, not in θ).
struct HybridParameters {
  Vec alpha, beta, x0;
  Vec gamma = {};
  int initial_mode = -1;
  static HybridParameters Of(const Model& model, const Vec& x0) {
    return {model.alpha(), model.beta(), x0, model.gamma()};
  }
  // γ, or the model's own when empty.
  const Vec& GammaOr(const Model& model) const { return gamma.size() ? gamma : model.gamma(); }
  // θ (the unknown entries, in the order of Unknowns) and back; γ must be filled when u.gamma is not
  // empty (std::logic_error otherwise).
  Vec Theta(const Unknowns& u) const;
  HybridParameters WithTheta(const Unknowns& u, const ConstVecRef& theta) const;
};

struct SensitivityOptions {
  SimOptions sim;             // tolerances (states and sensitivities alike), budgets, Zeno rule
  bool sensitivities = true;  // false: the states alone (cheaper; sensitivities left empty)
  bool IsValid(std::string* error) const;
};

struct SensitivityTrajectory {
  // t, j (the segment each sample was read from), x, jumps, status: as Simulate in plain mode.
  Trajectory trajectory;
  int parameters = 0;       // p
  Mat sensitivities;        // (n·p) × K: column k holds S_k (n × p, column-major); empty when not asked
  Mat jump_time_gradients;  // p × (jumps): ∂t_j/∂θ
  // Matched mode only: segments the model never reached before the last sample time (the samples
  // then stop at the last segment reached, status.message says so; use ok(), not the status alone),
  // and guard crossings on the last segment (the model jumps more often).
  int missing_jumps = 0;
  int extra_jumps = 0;
  bool ok() const { return trajectory.status.completed() && missing_jumps == 0; }
  // S_k as an n × p matrix.
  Eigen::Map<const Mat> S(long k) const {
    const auto n = trajectory.x.rows();
    return {sensitivities.col(k).data(), n, parameters};
  }
};

// Takes each sample's state and sensitivities as a run reads them, instead of the run storing S for
// every sample (SensitivityTrajectory::sensitivities is then left empty): a caller that only sums
// over the samples holds O(p²) numbers instead of n·p per sample. Samples come in any order (the
// matched mode reads a segment's early samples backward), each once; a run that stops early gives
// only the samples before its stop.
class SensitivitySink {
 public:
  virtual ~SensitivitySink() = default;
  // Sample k: its state ξ(t_k) (n entries) and S_k (n × p, column-major), valid during the call.
  virtual void Sample(long k, const double* x, const double* s) = 0;

  // Windows (a sink whose windows() is true): a sample read between two solver returns a and b
  // comes instead as WindowSample with the weights w (4 entries) of its cubic Hermite interpolation,
  //   S_k = w0·S_a + w1·S'_a + w2·S_b + w3·S'_b      (S' = dS/dt),
  // and once the window's samples are given, before its ends change, CloseWindow hands the four
  // ends (each n × p, column-major). A sample at the run's current state (at a jump, at a
  // segment's start) still comes as Sample. A sink that sums products of S_k over the samples can
  // then sum products of w per sample and apply the ends once per window (a solver step spans tens
  // of samples at the refinement's tolerances).
  virtual bool windows() const { return false; }
  virtual void WindowSample(long k, const double* x, const double* w);
  virtual void CloseWindow(const double* sa, const double* da, const double* sb, const double* db);
};

// Throws std::invalid_argument for a bad grid, options, unknowns, parameter vectors of the wrong
// size or not finite (x0 as Simulate), or inputs that do not fit the model or the samples' time range
// (`inputs`: the measured u(t) of a model with inputs, else nullptr; ExogenousError). Numerical
// outcomes are in trajectory.status.
SensitivityTrajectory SimulateSensitivities(const Model& model, const HybridParameters& params,
                                            const Unknowns& unknowns, const SampleGrid& grid,
                                            const SensitivityOptions& options = {},
                                            const InputSignal* inputs = nullptr);

// The same on samples at their own times (times[0] = 0, increasing): sample k at times[k], on the
// segment the model is in then (its own events).
SensitivityTrajectory SimulateSensitivities(const Model& model, const HybridParameters& params,
                                            const Unknowns& unknowns, const std::vector<double>& times,
                                            const SensitivityOptions& options = {},
                                            const InputSignal* inputs = nullptr);

// `segment_of_sample` has one entry per sample of the grid, at least 0 and never decreasing from one
// sample to the next (else std::invalid_argument naming the sample). A segment no sample names is one
// the model passes between two samples (several jumps inside one sample interval), or that a chain of
// jumps at one instant leaves at once (the first sample's label above 0: the initial state's chain);
// the model's own jump counts (SensitivityTrajectory::trajectory.j of a plain run) are such labels.
SensitivityTrajectory SimulateSensitivitiesMatched(const Model& model, const HybridParameters& params,
                                                   const Unknowns& unknowns, const SampleGrid& grid,
                                                   const std::vector<int>& segment_of_sample,
                                                   const SensitivityOptions& options = {},
                                                   const InputSignal* inputs = nullptr);
// The same on samples at their own times (irregular sampling; times[0] = 0, increasing): sample k at
// times[k] instead of k·δt. With a sink (and options.sensitivities) each sample's S_k goes to it and
// the trajectory's sensitivities stay empty.
SensitivityTrajectory SimulateSensitivitiesMatched(const Model& model, const HybridParameters& params,
                                                   const Unknowns& unknowns, const std::vector<double>& times,
                                                   const std::vector<int>& segment_of_sample,
                                                   const SensitivityOptions& options = {},
                                                   const InputSignal* inputs = nullptr,
                                                   SensitivitySink* sink = nullptr);

}  // namespace hysid
