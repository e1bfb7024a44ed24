// One fit of the output-error refinement: the chains as fit, the cost, the solve and its polish, the
// jump checks per chain and the residual checks pooled (sim/refine/fit.hpp).
#include "sim/refine/fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <ceres/ceres.h>
#include <fmt/format.h>

#include "core/model/automaton.hpp"
#include "core/model/noise_shape.hpp"
#include "sim/refine/budget.hpp"
#include "sim/refine/chain_sums.hpp"
#include "sim/refine/residual_tests.hpp"
#include "sim/refine/solver.hpp"
#include "sim/refine/span.hpp"

namespace hysid {

bool Admissible(const Model& model, const HybridParameters& p, const InputSignal& inputs) {
  if (!p.alpha.allFinite() || !p.beta.allFinite() || !p.x0.allFinite() || !p.gamma.allFinite()) return false;
  const Vec gamma = p.GammaOr(model);
  const Context at{.t = 0.0,
                   .u = inputs.empty() ? nullptr : inputs.values.col(0).data(),
                   .gamma = gamma.data(),
                   .alpha = p.alpha.data(),
                   .beta = p.beta.data(),
                   .mode = p.initial_mode >= 0 ? p.initial_mode : model.spec().default_mode};
  return model.InFlowSet(p.x0, at) || model.InJumpSet(p.x0, at);
}

// Integration accuracy per component: residuals below it are numerical, not noise.
Vec NumericalFloor(const Mat& y, const SimOptions& sim) {
  return (1e3 * (sim.rtol * y.cwiseAbs().rowwise().maxCoeff().array() + sim.atol)).matrix();
}

namespace {

// One chain as fit: the span used, its times from 0, its detected segments.
struct ChainFit {
  long index = 0;  // in the caller's list
  // The span's sample times from its first: the chain's own times when they start at 0 and the
  // whole chain is fit, else a copy (own_times).
  const std::vector<double>* chain_times = nullptr;
  std::vector<double> own_times;
  const std::vector<double>& times() const { return chain_times != nullptr ? *chain_times : own_times; }
  // The measured samples of the span (m × K): the chain's own first K columns when every state is
  // measured, else a copy of the measured rows.
  const SampleView* chain_y = nullptr;
  Mat measured_y;
  Eigen::Ref<const Mat> y() const {
    if (chain_y == nullptr) return measured_y;
    return chain_y->leftCols(static_cast<Eigen::Index>(times().size()));
  }
  std::vector<int> segments;
  Vec x0;
  InputSignal inputs;     // a model with inputs: u on the span, on the same clock as times
  std::vector<int> maps;  // a hybrid automaton: the map assigned to each detected event in the span
  int initial_mode = -1;  // its mode at the first sample (−1: the model's default_mode)
};

// p run on fit f: its initial mode.
HybridParameters OnChain(const ChainFit& f, HybridParameters p) {
  p.initial_mode = f.initial_mode;
  return p;
}


// The trajectory that stands for one that cannot be simulated (status left-domain, with the reason).
SensitivityTrajectory LeftDomain() {
  SensitivityTrajectory bad;
  bad.trajectory.status.stop = SimStop::kLeftDomain;
  bad.trajectory.status.message = "x0 outside C and D, or parameters not finite";
  return bad;
}

// One chain's run with sensitivities at a point, as the fit keeps it: whether it simulated (else
// why not), its sums (sim/refine/chain_sums.hpp), and its state and sensitivities (n × p) at its
// last sample (multiple shooting's continuity).
struct ChainEval {
  bool ok = false;
  bool sensitivities = true;  // false: a run of the states alone (the fit's final step)
  std::string message;
  ChainSums sums;
  Vec end;
  Mat end_sensitivities;
  std::vector<JumpRecord> jumps;  // the model's own jumps, one per detected segment after the first
  int extra_jumps = 0;            // guard crossings on the last segment (SensitivityTrajectory)
};

struct FitProblem {
  const Model* model = nullptr;
  Unknowns unknowns;  // α, β and x0: the sensitivity layout of one chain
  HybridParameters start;
  std::vector<ChainFit> fits;
  std::vector<int> rows;  // the measured components (RefineOptions::measured; all when it is empty)
  std::vector<int> held;  // the known components of the (one) chain's ξ0, as indices into the joint θ
  Vec weight;             // 1/σ_i per measured component
  SensitivityOptions options;
  int shared = 0;        // |α_u| + |β_u|
  // Multiple shooting: the fits c whose state at their last sample continues into fit c + 1's ξ0,
  // and the continuity residuals' weights 1/(w·σ_i) per state (FitStart::continues).
  std::vector<std::size_t> links;
  Vec link_weight;
  bool several = false;  // more than one chain given: messages name the chain
  ChainFailure failure;
  // Per fit: the last evaluation and its point (θ, ξ0_c). Every evaluation integrates the
  // sensitivities: Ceres asks for the Jacobian at the trial points it accepts, which are then the
  // last ones evaluated, and residuals and Jacobian come from one integration (the cost compared
  // across trial points is that of one integrator). Only the run's sums are kept.
  mutable std::vector<Vec> cached_at;
  mutable std::vector<ChainEval> cached;
  // Per fit: the CVODE steps of its last completed run (BudgetRun).
  mutable std::vector<long> completed_steps;

  HybridParameters At(const double* theta, const double* x0) const {
    Vec full(shared + model->state_size());
    full.head(shared) = Eigen::Map<const Vec>(theta, shared);
    full.tail(model->state_size()) = Eigen::Map<const Vec>(x0, model->state_size());
    return start.WithTheta(unknowns, full);
  }

  // Whether fit c's cached run is at p (its α, β, γ and ξ0).
  bool CachedAt(std::size_t c, const HybridParameters& p) const {
    const Vec point = p.Theta(unknowns);
    return cached_at[c].size() == point.size() && cached_at[c] == point;
  }

  // Fit c's matched trajectory with sensitivities at (θ, ξ0_c) (without: the states alone, whose
  // sums then have no G_i and h_i), as its sums, valid until the next call for c; ok false when it fails.
  const ChainEval& Evaluate(std::size_t c, const double* theta, const double* x0, bool sensitivities = true) const {
    const HybridParameters p = OnChain(fits[c], At(theta, x0));
    if (CachedAt(c, p) && (cached[c].sensitivities || !sensitivities)) return cached[c];
    cached_at[c].resize(0);
    // The run's S_k summed as they come (sim/refine/chain_sums.hpp): no run holds S for its samples.
    ChainSummer summer(fits[c].y(), rows, model->state_size(), unknowns.size(model->state_size()));
    SensitivityOptions o = options;
    o.sensitivities = sensitivities;
    BudgetRun(o, static_cast<long>(fits[c].times().size()), completed_steps[c]);
    const SensitivityTrajectory s =
        Admissible(*model, p, fits[c].inputs)
            ? SimulateSensitivitiesMatched(*model, p, unknowns, fits[c].times(), fits[c].segments, o,
                                           InputsOf(fits[c].inputs), sensitivities ? &summer : nullptr)
            : LeftDomain();
    if (s.trajectory.status.completed()) completed_steps[c] = s.trajectory.stats.steps;
    ChainEval& e = cached[c];
    e.ok = s.ok();
    e.sensitivities = sensitivities;
    e.message = s.trajectory.status.message;
    if (e.ok) {
      e.sums = summer.Finish(s.trajectory.x);
      e.end = s.trajectory.x.col(s.trajectory.x.cols() - 1);
      e.end_sensitivities = summer.last_sensitivities();
      e.jumps = s.trajectory.jumps;
      e.extra_jumps = s.extra_jumps;
    }
    if (e.ok && !e.sums.squares.allFinite()) {
      e.ok = false;
      e.message = "residuals not finite";
    }
    if (e.ok) cached_at[c] = p.Theta(unknowns);
    return e;
  }

  // "chain c: " when several chains are given, else "".
  std::string Label(std::size_t c) const {
    return several ? fmt::format("chain {}: ", fits[c].index + 1) : std::string();
  }
};

// One chain's weighted residuals to Ceres, compressed to p + 1 entries (sim/refine/chain_sums.hpp).
class ChainCost final : public ceres::CostFunction {
 public:
  ChainCost(const FitProblem& problem, std::size_t chain) : problem_(problem), chain_(chain) {
    set_num_residuals(problem.shared + problem.model->state_size() + 1);
    mutable_parameter_block_sizes()->push_back(problem.shared);
    mutable_parameter_block_sizes()->push_back(problem.model->state_size());
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const ChainEval& e = problem_.Evaluate(chain_, parameters[0], parameters[1]);
    if (!e.ok) return false;
    Mat j;
    CompressedResidual(e.sums, problem_.weight, residuals, &j);
    if (!Eigen::Map<const Vec>(residuals, j.rows()).allFinite()) return false;
    const int shared = problem_.shared, n = problem_.model->state_size();
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Eigen::Map<RowMajor>(jacobians[0], j.rows(), shared) = j.leftCols(shared);
    }
    if (jacobians != nullptr && jacobians[1] != nullptr) {
      Eigen::Map<RowMajor>(jacobians[1], j.rows(), n) = j.rightCols(n);
    }
    return true;
  }

 private:
  const FitProblem& problem_;
  std::size_t chain_;
};

// The continuity residuals of multiple shooting: (x_c(t_last; θ, ξ0_c) − ξ0_{c+1})/(w·σ_i), from fit
// c's cached run (no integration of its own), over θ's shared block, ξ0_c and ξ0_{c+1}.
class ContinuityCost final : public ceres::CostFunction {
 public:
  ContinuityCost(const FitProblem& problem, std::size_t chain) : problem_(problem), chain_(chain) {
    const int n = problem.model->state_size();
    set_num_residuals(n);
    mutable_parameter_block_sizes()->push_back(problem.shared);
    mutable_parameter_block_sizes()->push_back(n);
    mutable_parameter_block_sizes()->push_back(n);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const ChainEval& e = problem_.Evaluate(chain_, parameters[0], parameters[1]);
    if (!e.ok) return false;
    const Eigen::Index n = e.end.size();
    const Vec& w = problem_.link_weight;
    Eigen::Map<Vec> r(residuals, n);
    r = w.asDiagonal() * (e.end - Eigen::Map<const Vec>(parameters[2], n));
    if (!r.allFinite()) return false;
    if (jacobians == nullptr) return true;
    const int shared = problem_.shared;
    const Mat& sk = e.end_sensitivities;  // n × p
    for (Eigen::Index i = 0; i < n; ++i) {
      for (int c = 0; c < shared && jacobians[0] != nullptr; ++c) jacobians[0][i * shared + c] = w[i] * sk(i, c);
      for (Eigen::Index b = 0; b < n; ++b) {
        if (jacobians[1] != nullptr) jacobians[1][i * n + b] = w[i] * sk(i, shared + b);
        if (jacobians[2] != nullptr) jacobians[2][i * n + b] = i == b ? -w[i] : 0.0;
      }
    }
    return true;
  }

 private:
  const FitProblem& problem_;
  std::size_t chain_;
};

// The samples before the first detected jump that follows the previous one by fewer than
// `min_interval` samples (jumps that close are not resolved reliably: the part before them is fit).
long FitLength(const std::vector<std::uint8_t>& gamma, long min_interval) {
  long previous = 0;
  for (std::size_t k = 1; k < gamma.size(); ++k) {
    if (gamma[k] == 0) continue;
    const auto kk = static_cast<long>(k);
    if (previous > 0 && kk - previous < min_interval) return previous;
    previous = kk;
  }
  return static_cast<long>(gamma.size());
}

// The chains as fit from s: span rule and retry limits, too short or outside C ∪ D left out; each
// chain's samples and span reason in r.
std::vector<ChainFit> PrepareChains(const Model& model, const std::vector<RefineChain>& chains,
                                    const FitStart& s, const std::vector<int>& rows,
                                    const RefineOptions& options, RefineResult& r) {
  std::vector<ChainFit> fits;
  r.chain_x0.assign(chains.size(), Vec());
  r.chain_samples_used.assign(chains.size(), 0);
  r.chain_span_reason.assign(chains.size(), "");
  for (std::size_t c = 0; c < chains.size(); ++c) {
    const RefineChain& in = chains[c];
    const long whole = FitLength(s.gamma[c], options.min_jump_interval), used = std::min(whole, s.limit[c]);
    r.chain_span_reason[c] =
        used < whole ? s.reason[c] : (whole < in.y.cols() ? CloseJumpsReason(options) : "");
    if (const std::string out = LeftOut(model, in, used, s.start.GammaOr(model)); !out.empty()) {
      r.chain_span_reason[c] = out;
      ++r.chains_skipped;
      continue;
    }
    ChainFit f;
    f.index = static_cast<long>(c);
    if (std::ssize(rows) == in.y.rows()) {
      f.chain_y = &in.y;  // (rows are increasing: all of them, in order)
    } else {
      f.measured_y = in.y(rows, Eigen::seqN(0, used));
    }
    f.x0 = s.x0[c];
    for (const int i : options.x0_known) f.x0[i] = options.x0[i];  // (one chain only)
    if (in.t.front() == 0.0 && used == std::ssize(in.t)) {
      f.chain_times = &in.t;
    } else {
      for (long k = 0; k < used; ++k) f.own_times.push_back(in.t[static_cast<std::size_t>(k)] - in.t[0]);
    }
    int j = 0;
    f.segments.reserve(static_cast<std::size_t>(used));
    for (long k = 0; k < used; ++k) {
      j += (k > 0 && s.gamma[c][static_cast<std::size_t>(k)] != 0) ? 1 : 0;
      f.segments.push_back(j);
    }
    f.inputs = ChainInputs(in, used);
    f.initial_mode = in.initial_mode;
    if (!in.maps.empty()) f.maps.assign(in.maps.begin(), in.maps.begin() + std::min<long>(j, std::ssize(in.maps)));
    r.detected_jumps += j;
    r.samples_used += used;
    r.chain_samples_used[c] = used;
    fits.push_back(std::move(f));
  }
  r.chains_used = static_cast<long>(fits.size());
  for (std::size_t c = 0; c < chains.size(); ++c) {
    if (r.chain_span_reason[c].empty()) continue;
    r.span_reason += chains.size() == 1 ? r.chain_span_reason[c]
                                        : fmt::format("{}chain {}: {}", r.span_reason.empty() ? "" : "; ",
                                                      c + 1, r.chain_span_reason[c]);
  }
  return fits;
}

// The bounds of θ's shared entries (α_u, β_u, γ_u) from the spec's Parameter lower/upper.
void ThetaBounds(const FitProblem& problem, Vec* lower, Vec* upper) {
  const std::vector<const Parameter*> params = problem.unknowns.Parameters(*problem.model);
  lower->resize(problem.shared);
  upper->resize(problem.shared);
  for (int i = 0; i < problem.shared; ++i) {
    (*lower)[i] = params[static_cast<std::size_t>(i)]->lower;
    (*upper)[i] = params[static_cast<std::size_t>(i)]->upper;
  }
}

// The finite bounds as Ceres parameter bounds on θ's block.
void SetBounds(const FitProblem& problem, Vec& theta, ceres::Problem& cp) {
  Vec lower, upper;
  ThetaBounds(problem, &lower, &upper);
  for (int i = 0; i < problem.shared; ++i) {
    if (std::isfinite(lower[i])) cp.SetParameterLowerBound(theta.data(), i, lower[i]);
    if (std::isfinite(upper[i])) cp.SetParameterUpperBound(theta.data(), i, upper[i]);
  }
}

// The joint information of the weighted residuals over θ (shared, then x0 of each chain) from the
// chains' sums at the weights w (1/σ per measured component).
ChainInformation JointInformation(const FitProblem& problem, const Vec& w) {
  std::vector<Mat> blocks;
  for (const ChainEval& e : problem.cached) blocks.push_back(e.sums.Information(w));
  return ChainInformation::Of(blocks, problem.shared);
}

// The normal equations of the weighted residuals over the joint θ from the chains' cached sums:
// F = JᵀJ (per chain) and g = −Jᵀr.
void NormalEquations(const FitProblem& problem, ChainInformation& f, Vec& g) {
  const int s = problem.shared, n = problem.model->state_size();
  g = Vec::Zero(s + n * static_cast<Eigen::Index>(problem.cached.size()));
  for (std::size_t c = 0; c < problem.cached.size(); ++c) {
    const Vec gc = -problem.cached[c].sums.Gradient(problem.weight);
    g.head(s) += gc.head(s);
    g.segment(s + n * static_cast<Eigen::Index>(c), n) = gc.tail(n);
  }
  f = JointInformation(problem, problem.weight);
}

// The Newton decrement λ = √(gᵀF⁻¹g) at the point (theta, x0) of the cached evaluations (g the
// gradient of the weighted cost, F = JᵀJ): the Gauss–Newton step from there moves each unknown by
// at most λ standard errors (|δ_i| ≤ λ √(F⁻¹)_ii). Infinity when a chain's cached evaluation is at
// another point or F is not positive definite.
double NewtonDecrement(const FitProblem& problem, const Vec& theta, const std::vector<Vec>& x0) {
  for (std::size_t c = 0; c < problem.fits.size(); ++c) {
    const Vec point = problem.At(theta.data(), x0[c].data()).Theta(problem.unknowns);
    if (problem.cached_at[c].size() != point.size() || problem.cached_at[c] != point) {
      return std::numeric_limits<double>::infinity();
    }
  }
  ChainInformation joint;
  Vec g;
  NormalEquations(problem, joint, g);
  double lambda2 = 0.0;
  if (problem.held.empty()) {
    lambda2 = joint.InverseQuadratic(g);  // each chain's ξ0 eliminated
  } else {                                // known components of ξ0 (one chain): no step moves them
    std::vector<int> free;
    for (int i = 0; i < static_cast<int>(g.size()); ++i) {
      if (std::find(problem.held.begin(), problem.held.end(), i) == problem.held.end()) free.push_back(i);
    }
    const Eigen::LLT<Mat> fisher(joint.Joint()(free, free));
    if (fisher.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
    lambda2 = Vec(g(free)).dot(fisher.solve(Vec(g(free))));
  }
  return std::isfinite(lambda2) ? std::sqrt(std::max(lambda2, 0.0)) : std::numeric_limits<double>::infinity();
}

// A statistical fit is done when the next Gauss–Newton step is far below the standard errors:
// the estimates then stand within this fraction of a standard error of the least-squares point.
constexpr double kStepStandardErrors = 1e-3;
// ... or when that step is below this many standard errors and gains less cost than the integration
// error moves it (the cost of a trial point then says nothing about the step: at the fits'
// tolerances the cost of 40 001 samples moves by 0.05–0.3 between nearby points as CVODE's steps
// change, while a step of λ standard errors gains λ²/2); a quarter of a standard error adds at most
// 1/16 to an estimate's variance.
constexpr double kNoiseStepStandardErrors = 0.25;
// Steps from a point whose decrement is below this are Gauss–Newton steps in the quadratic region:
// their gain differs from the predicted one by the integration error, not by nonlinearity.
constexpr double kQuadraticRegion = 1.0;

// Ends the solve successfully after an accepted step (or at the start) whose Newton decrement λ is
// below kStepStandardErrors; with `final_step`, already once λ < kQuadraticRegion, leaving the last
// Gauss–Newton step to TakeFinalStep (final_step_due()); otherwise once λ < kNoiseStepStandardErrors
// and λ²/2 is below the largest difference between the actual and the predicted cost change of a
// step taken in the quadratic region (the cost's integration noise). Reads the parameter blocks,
// which Ceres updates every iteration.
class WithinStandardErrors final : public ceres::IterationCallback {
 public:
  WithinStandardErrors(const FitProblem& problem, const Vec& theta, const std::vector<Vec>& x0,
                       const RefineOptions& options, bool final_step)
      : problem_(problem), theta_(theta), x0_(x0), options_(options), final_step_(final_step) {}
  // The solve ended for TakeFinalStep, at a point whose decrement is lambda().
  bool final_step_due() const { return due_; }
  double lambda() const { return lambda_; }
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override {
    if (options_.stopped()) return ceres::SOLVER_ABORT;  // RefineOptions::stop or cancel
    // (Multiple shooting: the decrement leaves the continuity residuals out; Ceres' tolerances end it.)
    if (!problem_.links.empty()) return ceres::SOLVER_CONTINUE;
    if (summary.iteration > 0 && summary.step_is_valid && lambda_ < kQuadraticRegion &&
        summary.relative_decrease != 0.0 && std::isfinite(summary.relative_decrease)) {
      const double predicted = summary.cost_change / summary.relative_decrease;
      noise_ = std::max(noise_, std::abs(summary.cost_change - predicted));
    }
    if (summary.step_is_successful) {
      lambda_ = NewtonDecrement(problem_, theta_, x0_);
      if (lambda_ < kStepStandardErrors) return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
      due_ = final_step_ && lambda_ < kQuadraticRegion;
      if (due_) return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
    }
    return lambda_ < kNoiseStepStandardErrors && 0.5 * lambda_ * lambda_ < noise_
               ? ceres::SOLVER_TERMINATE_SUCCESSFULLY
               : ceres::SOLVER_CONTINUE;
  }

 private:
  const FitProblem& problem_;
  const Vec& theta_;
  const std::vector<Vec>& x0_;
  const RefineOptions& options_;
  bool final_step_ = false, due_ = false;
  double lambda_ = std::numeric_limits<double>::infinity();  // at the last accepted point
  double noise_ = 0.0;
};

// The Ceres solve: Levenberg–Marquardt with RefineOptions' iteration budget and tolerances, ended
// as well once the next Gauss–Newton step is below kStepStandardErrors (WithinStandardErrors); the
// normal equations for one chain, several chains' ξ0 blocks eliminated (Schur complement); one
// thread, Ceres' own logging silenced (the fit's status carries a failed evaluation).
ceres::Solver::Summary Solve(const FitProblem& problem, const RefineOptions& options, Vec& theta,
                             std::vector<Vec>& x0, WithinStandardErrors& within) {
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem cp(po);
  for (std::size_t c = 0; c < problem.fits.size(); ++c) {
    cp.AddResidualBlock(new ChainCost(problem, c), nullptr, theta.data(), x0[c].data());
  }
  for (const std::size_t c : problem.links) {
    cp.AddResidualBlock(new ContinuityCost(problem, c), nullptr, theta.data(), x0[c].data(), x0[c + 1].data());
  }
  const std::vector<int>& known = options.x0_known;  // one chain only
  if (!problem.fits.empty() && static_cast<int>(known.size()) == problem.model->state_size()) {
    cp.SetParameterBlockConstant(x0.front().data());
  } else if (!problem.fits.empty() && !known.empty()) {
    cp.SetManifold(x0.front().data(), new ceres::SubsetManifold(problem.model->state_size(), known));
  }
  SetBounds(problem, theta, cp);
  ceres::Solver::Options so = LevenbergMarquardt(options);
  // One chain: 6 or so unknowns in all, where eliminating ξ0 saves nothing and the Schur
  // eliminator's per-row block work costs more than forming JᵀJ; several: ξ0_c eliminated.
  so.linear_solver_type = problem.fits.size() == 1 ? ceres::DENSE_NORMAL_CHOLESKY : ceres::DENSE_SCHUR;
  so.callbacks.push_back(&within);
  so.update_state_every_iteration = true;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &cp, &summary);
  return summary;
}

// The first fitted jump more than `tolerance` samples from its detected interval (k: the sample
// after the detected jump; 0 when every jump is within it), in a run with one jump per detected one.
struct JumpOff {
  long k = 0;
  long jump = 0;  // from 1
  double t = 0.0, off = 0.0;
};
JumpOff FirstJumpOff(const ChainFit& f, const std::vector<JumpRecord>& jumps, double tolerance) {
  const SampleClock clock{.times = &f.times()};
  std::size_t j = 0;
  for (std::size_t k = 1; k < f.segments.size(); ++k) {
    if (f.segments[k] == f.segments[k - 1]) continue;
    const double t = jumps[j++].t, off = clock.Off(t, static_cast<long>(k));
    if (off > tolerance) return {static_cast<long>(k), static_cast<long>(j), t, off};
  }
  return {};
}

// The jump check passed by the fit's own run at the fit (matched, sim/sensitivity): its segments
// start at the model's own jumps, each the first guard crossing after the one before, so a run that
// completes with no crossing left on its last segment has the model on its own jump once per
// detected jump, at those times. False (the model on its own is then run and checked) when the
// cached run is not at `fit`, did not complete, crossed a guard on its last segment, has jump maps to
// compare, or one of its jumps is off its detected interval.
bool MatchedJumpsPass(const FitProblem& problem, std::size_t c, const HybridParameters& fit,
                      const RefineOptions& options) {
  const ChainFit& f = problem.fits[c];
  const ChainEval& e = problem.cached[c];
  if (!f.maps.empty() || !problem.CachedAt(c, OnChain(f, fit)) || !e.ok || e.extra_jumps != 0 ||
      std::ssize(e.jumps) != f.segments.back()) {
    return false;
  }
  return FirstJumpOff(f, e.jumps, options.jump_time_tolerance).k == 0;
}

// The last three jump intervals shrink and the last two are below one sample step: the jumps
// accumulate faster than the samples can show (a Zeno approach).
bool AccumulatesWithinASample(const std::vector<JumpRecord>& jumps, double step) {
  const std::size_t m = jumps.size();
  if (m < 4) return false;
  const double i1 = jumps[m - 1].t - jumps[m - 2].t, i2 = jumps[m - 2].t - jumps[m - 3].t,
               i3 = jumps[m - 3].t - jumps[m - 4].t;
  return i1 < i2 && i2 < i3 && i2 < step;
}

// The model at p on its own over fit f's span (plain mode, states only): its jumps are what the
// checks compare with the detected ones. The grid's step is the chain's mean step (only the jumps,
// located by root finding, are read).
SensitivityTrajectory SimulateOnItsOwn(const FitProblem& problem, const ChainFit& f,
                                       const HybridParameters& p) {
  if (!Admissible(*problem.model, p, f.inputs)) return LeftDomain();
  SensitivityOptions o = problem.options;
  o.sensitivities = false;
  const double t_end = f.times().back();
  const SampleGrid grid = EvenGrid(t_end, static_cast<long>(f.times().size()));
  return SimulateSensitivities(*problem.model, OnChain(f, p), problem.unknowns, grid, o, InputsOf(f.inputs));
}

// The first disagreement of fit c's model on its own at p with its detected jumps (more than
// `tolerance` samples apart, or a jump without a counterpart), noted for the span retries.
void NoteFailure(FitProblem& problem, std::size_t c, const SensitivityTrajectory& plain, double tolerance) {
  const ChainFit& f = problem.fits[c];
  problem.failure = ChainFailure{.chain = f.index, .disagreement = -1, .model_jumps = {}};
  if (plain.trajectory.status.stop == SimStop::kLeftDomain) return;
  problem.failure.disagreement =
      FirstDisagreement(plain.trajectory.jumps, f.segments, SampleClock{.times = &f.times()}, tolerance);
}

// A hybrid automaton with maps assigned to the detected events: the fitted model's jumps apply the
// same sequence of maps (its jump count already agrees).
void CheckMaps(const Model& model, const ChainFit& f, const std::vector<JumpRecord>& jumps, const std::string& label,
               RefineResult& r) {
  for (std::size_t j = 0; j < f.maps.size() && j < jumps.size() && r.ok(); ++j) {
    if (jumps[j].map == f.maps[j]) continue;
    const std::vector<JumpMap> maps = JumpMaps(model.spec());
    auto name = [&](int m) { return m >= 0 && m < std::ssize(maps) ? maps[std::size_t(m)].name : "?"; };
    Fail(r, RefineStatus::kJumpCountMismatch,
         fmt::format("{}fitted jump {} at t = {:.6g} applies map '{}'; the event was assigned to '{}'", label, j + 1,
                     jumps[j].t, name(jumps[j].map), name(f.maps[j])));
  }
}

// Fit c's model on its own at the fit against its detected jumps: Zeno, count, times, and the maps
// assigned (a hybrid automaton); a failure is noted for the span retries. Adds its jumps to r.model_jumps.
void CheckJumps(FitProblem& problem, std::size_t c, const HybridParameters& fit, const RefineOptions& options,
                RefineResult& r) {
  const ChainFit& f = problem.fits[c];
  if (MatchedJumpsPass(problem, c, fit, options)) {
    r.model_jumps += f.segments.back();
    return;
  }
  const SensitivityTrajectory plain = SimulateOnItsOwn(problem, f, fit);
  const std::vector<JumpRecord>& jumps = plain.trajectory.jumps;
  const SimStatus& st = plain.trajectory.status;
  const int model = static_cast<int>(jumps.size()), detected = f.segments.back();
  r.model_jumps += model;
  if (!r.ok()) return;  // an earlier chain failed: only the jumps are counted
  const std::string label = problem.Label(c);
  const double step = f.times().back() / static_cast<double>(f.times().size() - 1);
  if (st.stop == SimStop::kZeno) {
    Fail(r, RefineStatus::kZeno, fmt::format("{}the fitted model is Zeno: {}", label, st.message));
  } else if (!st.completed()) {
    Fail(r, RefineStatus::kNotConverged,
         fmt::format("{}the fitted model does not simulate: {}: {}", label, ToString(st.stop), st.message));
  } else if (model != detected && AccumulatesWithinASample(jumps, step)) {
    Fail(r, RefineStatus::kZeno,
         fmt::format("{}the fitted model's jumps accumulate (Zeno) near t = {:.6g}: {} jumps, the last ones "
                     "less than a sample apart, against {} detected",
                     label, jumps.back().t, model, detected));
  } else if (model != detected) {
    Fail(r, RefineStatus::kJumpCountMismatch,
         fmt::format("{}the fitted model jumps {} times, the detector found {}", label, model, detected));
  } else {
    if (const JumpOff off = FirstJumpOff(f, jumps, options.jump_time_tolerance); off.k > 0) {
      const auto k = static_cast<std::size_t>(off.k);
      Fail(r, RefineStatus::kJumpCountMismatch,
           fmt::format("{}fitted jump {} at t = {:.6g} is {:.3g} samples from the detected interval "
                       "({:.6g}, {:.6g}]",
                       label, off.jump, off.t, off.off, f.times()[k - 1], f.times()[k]));
    }
    if (r.ok()) CheckMaps(*problem.model, f, jumps, label, r);
  }
  if (r.ok()) return;
  NoteFailure(problem, c, plain, options.jump_time_tolerance);
  for (const JumpRecord& jump : jumps) problem.failure.model_jumps.push_back(jump.t);
}

// The names of the joint θ: the shared unknowns, then x0 of each fitted chain (" chain c" when several).
std::vector<std::string> JointNames(const FitProblem& problem) {
  const std::vector<std::string> all = problem.unknowns.Names(*problem.model);
  std::vector<std::string> names(all.begin(), all.begin() + problem.shared);
  for (const ChainFit& f : problem.fits) {
    for (std::size_t i = static_cast<std::size_t>(problem.shared); i < all.size(); ++i) {
      names.push_back(problem.several ? fmt::format("{} chain {}", all[i], f.index + 1) : all[i]);
    }
  }
  return names;
}

// The residual checks from the residuals' sums of squares and lag-1 sums per component (pooled over
// the chains), with the σ they are normalised by, the residual σ̂, its MAD estimate from the data,
// the floor and the number of unknowns: sets normalized_rms and lag1, and fails with kResidualRms
// (σ given: Σ(r/σ)² refused by its χ² test; with σ estimated, σ̂ over the MAD estimate above
// rms_high) or kResidualCorrelation (√N ρ̂₁ refused by its test while the residuals are above the
// floor); both tests at RefineOptions::residual_test_size (sim/refine/residual_tests.hpp).
void JudgeResiduals(const Vec& squares, const Vec& lags, long samples, double parameters, const Vec& sigma,
                    const Vec& sigma_hat, const Vec& mad_sigma, const Vec& floor, const RefineOptions& options,
                    RefineResult& r) {
  const Vec w2 = sigma.cwiseInverse().cwiseAbs2();
  const double z2 = w2.dot(squares), lag = w2.dot(lags);
  const long residuals = samples * squares.size();
  const ResidualLimits limits = ResidualLimitsFor(residuals, parameters, options.residual_test_size);
  r.normalized_rms = r.sigma_estimated ? SigmaOverMad(sigma_hat, mad_sigma, floor)
                                       : std::sqrt(z2 / static_cast<double>(residuals));
  r.lag1 = z2 > 0.0 ? lag / z2 : 0.0;
  const bool above_floor = (sigma_hat.array() > floor.array()).all();
  if (r.sigma_estimated ? r.normalized_rms > options.rms_high
                        : z2 > limits.level_high || (above_floor && z2 < limits.level_low)) {
    return Fail(r, RefineStatus::kResidualRms,
                r.sigma_estimated
                    ? fmt::format("residual sigma over the MAD estimate {:.4g} > {:g}", r.normalized_rms, options.rms_high)
                    : fmt::format("normalised residual RMS {:.4g}: Σ(r/σ)² = {:.6g} outside [{:.6g}, {:.6g}] (the χ² "
                                  "test of size {:g} over {} residuals)",
                                  r.normalized_rms, z2, limits.level_low, limits.level_high,
                                  options.residual_test_size / 2, residuals));
  }
  const double z = std::sqrt(static_cast<double>(residuals)) * r.lag1;
  if (above_floor && std::abs(z) > limits.z) {
    return Fail(r, RefineStatus::kResidualCorrelation,
                fmt::format("lag-1 autocorrelation of the residuals {:.4g} (√N·ρ₁ = {:.3g}, beyond {:.3g}: the "
                            "test of size {:g}): the model or the detected jumps do not fit the data",
                            r.lag1, z, limits.z, options.residual_test_size / 2));
  }
}

// The residuals' sums of squares per measured component over every fitted span at the fit (and of
// their lag-1 products within chains when lags is given); the samples counted.
long PooledSquares(const FitProblem& problem, Vec* squares, Vec* lags = nullptr) {
  const auto m = static_cast<Eigen::Index>(problem.rows.size());
  *squares = Vec::Zero(m);
  if (lags) *lags = Vec::Zero(m);
  long samples = 0;
  for (const ChainEval& e : problem.cached) {
    *squares += e.sums.squares;
    if (lags) *lags += e.sums.lag;
    samples += e.sums.samples;
  }
  return samples;
}

// The floor of every measured component over the fitted spans (NumericalFloor of their samples).
Vec PooledFloor(const FitProblem& problem) {
  Vec largest = Vec::Zero(static_cast<Eigen::Index>(problem.rows.size()));
  for (const ChainFit& f : problem.fits) largest = largest.cwiseMax(f.y().cwiseAbs().rowwise().maxCoeff());
  return NumericalFloor(largest, problem.options.sim);
}

// DeterminedSd of the joint information without the held entries (known: sd 0), its first
// `reported` entries (the shared unknowns and the first fitted chain's ξ0); empty above
// RefineResult::kMaxDeterminedSize rows.
Vec DeterminedReported(const Mat& fisher, const std::vector<int>& held, int reported) {
  if (fisher.rows() > RefineResult::kMaxDeterminedSize) return {};
  std::vector<Eigen::Index> free;
  for (Eigen::Index i = 0; i < fisher.rows(); ++i) {
    if (std::find(held.begin(), held.end(), static_cast<int>(i)) == held.end()) free.push_back(i);
  }
  const Vec sd = DeterminedSd(fisher(free, free));
  if (sd.size() == 0) return {};
  Vec out = Vec::Zero(fisher.rows());
  out(free) = sd;
  return out.head(reported);
}

// The covariance of the reported unknowns (the shared ones and the first fitted chain's ξ0) at σ:
// the block of the joint Fisher information's inverse; the same block with each fitted chain's ξ0 in
// r.chain_covariance. Several chains (no ξ0 held): each chain's ξ0 eliminated (ChainInformation),
// the joint matrix formed only when that finds it singular, for CrlbFromFisher's verdict and message.
// False with kSingularFisher.
bool Covariance(const FitProblem& problem, const Vec& sigma, RefineResult& r) {
  const ChainInformation joint = JointInformation(problem, sigma.cwiseInverse());
  const int shared = problem.shared, n = problem.model->state_size();
  r.chain_covariance.assign(r.chain_x0.size(), Mat());
  if (problem.held.empty() && problem.fits.size() > 1) {
    bool blocks = true;
    for (std::size_t c = 0; c < problem.fits.size() && blocks; ++c)
      blocks = joint.CovarianceBlock(c, &r.chain_covariance[std::size_t(problem.fits[c].index)]);
    if (blocks) {
      r.covariance = r.chain_covariance[std::size_t(problem.fits.front().index)];
      r.standard_errors = r.covariance.diagonal().cwiseSqrt();
      return true;
    }
    r.chain_covariance.assign(r.chain_x0.size(), Mat());
  }
  const Mat fisher = joint.Joint();
  const Crlb bound = CrlbFromFisher(fisher, problem.unknowns, JointNames(problem), problem.held);
  if (!bound.ok()) {
    r.covariance.resize(0, 0);
    Fail(r, RefineStatus::kSingularFisher, bound.message);
    r.determined_standard_errors = DeterminedReported(fisher, problem.held, shared + n);
    return false;
  }
  // The joint order: the shared entries, then each chain's ξ0 in problem.fits' order.
  for (std::size_t c = 0; c < problem.fits.size(); ++c) {
    std::vector<Eigen::Index> idx;
    for (int i = 0; i < shared; ++i) idx.push_back(i);
    for (int i = 0; i < n; ++i) idx.push_back(shared + n * static_cast<Eigen::Index>(c) + i);
    r.chain_covariance[std::size_t(problem.fits[c].index)] = bound.covariance(idx, idx);
  }
  r.covariance = r.chain_covariance[std::size_t(problem.fits.front().index)];
  r.standard_errors = bound.sd.head(shared + n);
  return true;
}

// σ, the covariance of the reported unknowns (α, β, the first fitted chain's ξ0), normalised RMS and
// lag-1 (within chains), pooled over the chains.
void CheckResiduals(const FitProblem& problem, const Vec& mad_sigma, const RefineOptions& options, RefineResult& r) {
  const int n = problem.model->state_size();
  const auto m = static_cast<int>(problem.rows.size());
  Vec squares, lags;
  const long samples = PooledSquares(problem, &squares, &lags);
  const double p = problem.shared + n * static_cast<double>(problem.cached.size());
  const Vec sigma_hat = (squares / (static_cast<double>(samples) - p / m)).cwiseSqrt();
  const Vec floor = PooledFloor(problem);
  r.sigma_estimated = options.sigma.size() == 0;
  // Noise-free: the accuracy.
  const Vec sigma = (r.sigma_estimated ? sigma_hat : options.sigma).cwiseMax(1e-3 * floor);
  r.sigma = Vec::Zero(n);
  r.sigma(problem.rows) = sigma;
  if (!Covariance(problem, sigma, r)) {
    RefineResult tests;  // the residual tests alone: r keeps singular-fisher
    tests.sigma_estimated = r.sigma_estimated;
    JudgeResiduals(squares, lags, samples, p, sigma, sigma_hat, mad_sigma, floor, options, tests);
    r.at_the_noise = tests.ok();
    if (!r.at_the_noise) r.determined_standard_errors.resize(0);
    return;
  }
  JudgeResiduals(squares, lags, samples, p, sigma, sigma_hat, mad_sigma, floor, options, r);
  r.at_the_noise = r.ok();
}

// Each chain simulated at (theta, x0), the runs' sums left in problem.cached; -1, or the first chain
// that does not simulate with `failure` naming it.
long SimulateAll(const FitProblem& problem, const Vec& theta, const std::vector<Vec>& x0,
                 RefineStatus failure, const char* what, RefineResult& r) {
  for (std::size_t c = 0; c < problem.fits.size(); ++c) {
    const ChainEval& e = problem.Evaluate(c, theta.data(), x0[c].data());
    if (!e.ok) {
      Fail(r, failure, fmt::format("{}{}: {}", problem.Label(c), what, e.message));
      return static_cast<long>(c);
    }
  }
  return -1;
}

// How far two integrations of the cost ½Σ w_i² r_ik² at one point may differ: each residual moved by
// up to the integration's error ε_i = rtol·max_k |y_ik| + atol, K such changes of random sign
// against residuals of about σ_i = 1/w_i, 2√K Σ_i w_i ε_i (at 40 001 samples of the §5 run at σ =
// 0.25: 0.018; the runs with and without sensitivities were measured 0.011 apart).
double IntegrationCostError(const FitProblem& problem) {
  double error = 0.0;
  long samples = 0;
  for (const ChainFit& f : problem.fits) samples += static_cast<long>(f.times().size());
  const SimOptions& sim = problem.options.sim;
  for (const ChainFit& f : problem.fits) {
    const Vec largest = f.y().cwiseAbs().rowwise().maxCoeff();
    error = std::max(error, problem.weight.dot((sim.rtol * largest.array() + sim.atol).matrix()));
  }
  return 2.0 * std::sqrt(static_cast<double>(samples)) * error;
}

// The last Gauss–Newton step of a fit of one chain (no continuity links), from the last accepted
// point, whose decrement λ is below kQuadraticRegion: δ = F⁻¹g from that point's sums (known ξ0
// components held), and at θ + δ a run of the states alone, whose residual sums and jumps the checks
// read; G_i stay the last point's, a step of at most λ standard errors away (the covariance). Kept
// when θ + δ is within the bounds, simulates, and costs at most λ²/2 (the step's predicted gain) plus
// the cost's integration error more than the last point (the run without sensitivities takes other
// steps: IntegrationCostError); else false, with theta, x0 and the cached run at the last point as
// they were.
bool TakeFinalStep(const FitProblem& problem, double lambda, Vec& theta, std::vector<Vec>& x0, RefineResult& r) {
  ChainInformation joint;
  Vec g;
  NormalEquations(problem, joint, g);
  std::vector<int> free;
  for (int i = 0; i < static_cast<int>(g.size()); ++i) {
    if (std::find(problem.held.begin(), problem.held.end(), i) == problem.held.end()) free.push_back(i);
  }
  const Eigen::LLT<Mat> fisher(joint.Joint()(free, free));
  if (fisher.info() != Eigen::Success) return false;
  Vec delta = Vec::Zero(g.size());
  const Vec step = fisher.solve(Vec(g(free)));
  delta(free) = step;
  const Vec next_theta = theta + delta.head(problem.shared), next_x0 = x0.front() + delta.tail(x0.front().size());
  Vec lower, upper;
  ThetaBounds(problem, &lower, &upper);
  if (!next_theta.allFinite() || (next_theta.array() < lower.array()).any() || (next_theta.array() > upper.array()).any()) {
    return false;
  }
  const ChainEval last = problem.cached.front();
  const Vec last_at = problem.cached_at.front();
  const double before = 0.5 * last.sums.Cost(problem.weight);
  const ChainEval& e = problem.Evaluate(0, next_theta.data(), next_x0.data(), /*sensitivities=*/false);
  const double after = e.ok ? 0.5 * e.sums.Cost(problem.weight) : std::numeric_limits<double>::infinity();
  if (!(after <= before + 0.5 * lambda * lambda + IntegrationCostError(problem))) {
    problem.cached.front() = last;
    problem.cached_at.front() = last_at;
    return false;
  }
  problem.cached.front().sums.gram = last.sums.gram;
  problem.cached.front().sums.h = last.sums.h;
  theta = next_theta;
  x0.front() = next_x0;
  r.final_cost = after;
  ++r.iterations;
  return true;
}

// A Ceres solve from (theta, x0), then each chain at the fit: the last Gauss–Newton step taken by
// TakeFinalStep when the solve left it (one chain), else (or when that step is not kept: at the last
// point when its decrement is below kNoiseStepStandardErrors, else after the solve goes on from
// there without it) each chain's run with sensitivities there. Adds the
// iterations to r, sets its final cost (and *initial_cost when given); false with kNotConverged
// ("LABEL: Ceres' message") or the chain that does not simulate. The runs at the fit are in
// problem.cached.
bool SolveAndSimulate(const FitProblem& problem, const RefineOptions& options, const char* label, Vec& theta,
                      std::vector<Vec>& x0, RefineResult& r, double* initial_cost = nullptr) {
  bool final_step = problem.links.empty() && problem.fits.size() == 1;
  for (int solve = 0; solve < 2; ++solve) {
    WithinStandardErrors within(problem, theta, x0, options, final_step);
    const ceres::Solver::Summary summary = Solve(problem, options, theta, x0, within);
    r.iterations += static_cast<int>(summary.iterations.size());
    if (initial_cost && solve == 0) *initial_cost = summary.initial_cost;
    r.final_cost = summary.final_cost;
    const bool converged =
        summary.termination_type == ceres::CONVERGENCE || summary.termination_type == ceres::USER_SUCCESS;
    if (!converged || !theta.allFinite()) {
      Fail(r, RefineStatus::kNotConverged, fmt::format("{}: {}", label, summary.message));
      return false;
    }
    if (!within.final_step_due()) break;
    if (TakeFinalStep(problem, within.lambda(), theta, x0, r)) return true;
    // Not kept: below a quarter of a standard error the last point stands (the runs without and with
    // sensitivities integrate the cost apart by more than the step's gain), else the solve goes on.
    if (within.lambda() < kNoiseStepStandardErrors) break;
    final_step = false;
  }
  return SimulateAll(problem, theta, x0, RefineStatus::kNotConverged, "the fit does not simulate", r) < 0;
}

// Residuals at the integration accuracy in every component (noise-free data): each component's
// residual σ̂_i, pooled over the chains, below that component's own floor (components differ in
// scale, and so do their integration errors).
bool AtIntegrationAccuracy(const FitProblem& problem) {
  Vec squares;
  const long samples = PooledSquares(problem, &squares);
  const Vec sigma_hat = (squares / static_cast<double>(samples)).cwiseSqrt();
  return (sigma_hat.array() < PooledFloor(problem).array()).all();
}

// Solve, polish for noise-free data, then the checks at the fit.
void RunFit(FitProblem& problem, const RefineOptions& options, const Vec& mad_sigma, RefineResult& r) {
  Vec theta = r.start.Theta(Unknowns{problem.unknowns.alpha, problem.unknowns.beta, problem.unknowns.gamma, false});
  Vec lower, upper;  // a start the data give outside the bounds starts on the nearest one
  ThetaBounds(problem, &lower, &upper);
  theta = theta.cwiseMax(lower).cwiseMin(upper);
  std::vector<Vec> x0;
  for (const ChainFit& f : problem.fits) x0.push_back(f.x0);
  if (const long bad = SimulateAll(problem, theta, x0, RefineStatus::kStartFailed,
                                   "the start does not simulate on the detected segments", r);
      bad >= 0) {
    // The start's jump times drift from the data (it is not fit yet): only its jump count is compared.
    const auto c = static_cast<std::size_t>(bad);
    const HybridParameters at = problem.At(theta.data(), x0[c].data());
    return NoteFailure(problem, c, SimulateOnItsOwn(problem, problem.fits[c], at),
                       std::numeric_limits<double>::infinity());
  }
  if (!SolveAndSimulate(problem, options, "Ceres", theta, x0, r, &r.initial_cost)) return;
  if (options.polish_tolerance < problem.options.sim.rtol && AtIntegrationAccuracy(problem)) {
    problem.options.sim.rtol = problem.options.sim.atol = options.polish_tolerance;
    for (Vec& at : problem.cached_at) at.resize(0);  // integrated at the looser tolerances
    // More steps at the tighter tolerances: the budget starts afresh.
    std::fill(problem.completed_steps.begin(), problem.completed_steps.end(), 0);
    if (!SolveAndSimulate(problem, options, "Ceres (polish)", theta, x0, r)) return;
  }
  r.refined = problem.At(theta.data(), x0.front().data());
  r.model_jumps = 0;
  for (std::size_t c = 0; c < problem.fits.size(); ++c) {
    r.chain_x0[static_cast<std::size_t>(problem.fits[c].index)] = x0[c];
    CheckJumps(problem, c, problem.At(theta.data(), x0[c].data()), options, r);
  }
  if (r.ok()) CheckResiduals(problem, mad_sigma, options, r);
}

// The continuity width w of multiple shooting: a defect of w·σ_i costs as much as one sample's
// residual of one σ.
constexpr double kContinuityWidth = 1e-2;

// The continuity links of s (FitStart::continues) between fits that stand side by side, chain c fit
// whole; their weights 1/(w·σ_i) (an unmeasured state: the largest measured weight).
void LinkShootingSegments(const std::vector<RefineChain>& chains, const FitStart& s, const RefineResult& r,
                          FitProblem& problem) {
  const int n = problem.model->state_size();
  for (std::size_t i = 0; i + 1 < problem.fits.size(); ++i) {
    const auto c = static_cast<std::size_t>(problem.fits[i].index);
    if (c < s.continues.size() && s.continues[c] != 0 && problem.fits[i + 1].index == problem.fits[i].index + 1 &&
        r.chain_samples_used[c] == chains[c].y.cols()) {
      problem.links.push_back(i);
    }
  }
  problem.link_weight = Vec::Constant(n, problem.weight.maxCoeff() / kContinuityWidth);
  for (std::size_t r_i = 0; r_i < problem.rows.size(); ++r_i) {
    problem.link_weight[problem.rows[r_i]] = problem.weight[static_cast<Eigen::Index>(r_i)] / kContinuityWidth;
  }
}

}  // namespace

// The CVODE steps one simulation of a fit may take per sample (the budget is also capped by
// RefineOptions::sensitivity.sim.max_steps), as for a segment of multiple shooting by time: the
// test suite's fits take at most 21 per sample where their runs succeed; a trial point that chatters
// spends the whole budget before it fails.
constexpr long kMaxStepsPerSample = 200;

void FitWeighting(const Mat& y, const RefineOptions& options, const Vec& mad_sigma, SensitivityOptions* sens,
                  Vec* weight) {
  FitWeighting(y.cwiseAbs().rowwise().maxCoeff(), static_cast<long>(y.cols()), options, mad_sigma, sens,
               weight);
}

void FitWeighting(const Vec& largest, long samples, const RefineOptions& options, const Vec& mad_sigma,
                  SensitivityOptions* sens, Vec* weight) {
  const Vec weighting = options.sigma.size() ? options.sigma : mad_sigma;
  *sens = options.sensitivity;
  // The work of one simulation grows with the data, not without bound: a trial point whose flow
  // needs more than kMaxStepsPerSample CVODE steps per sample is far from data sampled that coarsely
  // (δt longer than the time between jumps made a fit take a minute); its evaluation fails and
  // Ceres steps back.
  sens->sim.max_steps = std::min(sens->sim.max_steps, kMaxStepsPerSample * samples);
  const double scale = std::max(1.0, largest.maxCoeff());
  const double tolerance = std::clamp(options.noise_tolerance * weighting.minCoeff() / scale,
                                      std::min(options.polish_tolerance, options.sensitivity.sim.rtol),
                                      options.sensitivity.sim.rtol);
  sens->sim.rtol = sens->sim.atol = tolerance;
  *weight = weighting.cwiseMax(1e-3 * NumericalFloor(largest, sens->sim)).cwiseInverse();
}

std::vector<int> MeasuredRows(const RefineOptions& options, int n) {
  if (!options.measured.empty()) return options.measured;
  std::vector<int> all(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) all[static_cast<std::size_t>(i)] = i;
  return all;
}

std::string LeftOut(const Model& model, const RefineChain& chain, long used, const Vec& gamma) {
  const int n = model.state_size();
  if (used < 2 * n + 2) return fmt::format("left out: {} samples to fit, fewer than {}", used, 2 * n + 2);
  const Context at{.t = chain.t.empty() ? 0.0 : chain.t.front(),
                   .u = chain.u.rows() > 0 ? chain.u.col(0).data() : nullptr,
                   .gamma = gamma.data()};
  if (!model.InFlowSet(chain.y.col(0), at) && !model.InJumpSet(chain.y.col(0), at)) {
    return "left out: the first sample lies outside C and D";
  }
  return "";
}

InputSignal ChainInputs(const RefineChain& chain, long used) {
  InputSignal s;
  if (chain.u.rows() == 0) return s;
  for (long k = 0; k < used; ++k) s.times.push_back(chain.t[static_cast<std::size_t>(k)] - chain.t.front());
  s.values = chain.u.leftCols(used);
  return s;
}

void MoveTo(const RefineResult& r, FitStart& s) {
  s.start.alpha = r.refined.alpha;
  s.start.beta = r.refined.beta;
  s.start.gamma = r.refined.gamma;
  for (std::size_t i = 0; i < s.x0.size() && i < r.chain_x0.size(); ++i) {
    if (r.chain_x0[i].size() != 0) s.x0[i] = r.chain_x0[i];
  }
}

void Fail(RefineResult& r, RefineStatus status, std::string reason) {
  r.status = status;
  r.reason = std::move(reason);
  r.determined_standard_errors.resize(0);
}

RefineResult FitChains(const Model& model, const std::vector<RefineChain>& chains, const FitStart& s,
                       const RefineOptions& options, ChainFailure* failure) {
  const int n = model.state_size();
  RefineResult r;
  r.unknowns = Unknowns::Of(model);
  r.names = r.unknowns.Names(model);
  r.start = r.refined = r.estimate = s.start;
  FitProblem problem;
  problem.model = &model;
  problem.unknowns = r.unknowns;
  problem.shared = r.unknowns.size(n) - n;
  problem.several = chains.size() > 1;
  problem.rows = MeasuredRows(options, n);
  for (const int i : options.x0_known) problem.held.push_back(problem.shared + i);
  const auto m = static_cast<double>(problem.rows.size());
  problem.fits = PrepareChains(model, chains, s, problem.rows, options, r);
  if (!problem.fits.empty()) r.start.x0 = r.refined.x0 = r.estimate.x0 = problem.fits.front().x0;
  const double p = problem.shared + static_cast<double>(n) * static_cast<double>(problem.fits.size());
  if (problem.fits.empty() || problem.shared == 0 || static_cast<double>(r.samples_used) < p / m + 2) {
    Fail(r, RefineStatus::kTooFewSamples,
         fmt::format("{} samples in {} chain(s) ({} left out: fewer than {} samples or a first sample outside "
                     "C and D) for {} unknowns",
                     r.samples_used, r.chains_used, r.chains_skipped, 2 * n + 2, p));
    return r;
  }
  Vec mad_sigma(problem.rows.size()), largest(problem.rows.size());
  {  // one component's second differences over all chains' samples in order, only while the weighting is chosen
    std::vector<double> d;
    d.reserve(static_cast<std::size_t>(std::max<Eigen::Index>(r.samples_used - 2, 0)));
    for (Eigen::Index i = 0; i < mad_sigma.size(); ++i) {
      d.clear();
      double before = 0.0, last = 0.0;  // the two samples before the next
      Eigen::Index seen = 0;
      largest[i] = 0.0;
      for (const ChainFit& f : problem.fits) {
        for (Eigen::Index c = 0; c < f.y().cols(); ++c, ++seen) {
          const double v = f.y()(i, c);
          if (seen >= 2) d.push_back(v - 2.0 * last + before);
          before = last;
          last = v;
          largest[i] = std::max(largest[i], std::abs(v));
        }
      }
      mad_sigma[i] = NoiseSigmaFromSecondDifferences(d);
    }
  }
  FitWeighting(largest, r.samples_used, options, mad_sigma, &problem.options, &problem.weight);
  problem.start = r.start;
  problem.cached_at.resize(problem.fits.size());
  problem.cached.resize(problem.fits.size());
  problem.completed_steps.assign(problem.fits.size(), 0);
  LinkShootingSegments(chains, s, r, problem);
  problem.options.sensitivities = true;  // every evaluation (FitProblem::Evaluate)
  RunFit(problem, options, mad_sigma, r);
  *failure = problem.failure;
  return r;
}

}  // namespace hysid
