#include "sim/refine/refine.hpp"
#include "sim/refine/solve.hpp"
#include "sim/refine/span.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

#include <ceres/ceres.h>
#include <fmt/format.h>
#include <glog/logging.h>

#include "core/model/noise_shape.hpp"

namespace hysid {

const char* ToString(RefineStatus status) {
  switch (status) {
    case RefineStatus::kOk: return "ok";
    case RefineStatus::kNonFiniteData: return "non-finite-data";
    case RefineStatus::kTooFewSamples: return "too-few-samples";
    case RefineStatus::kStartFailed: return "start-failed";
    case RefineStatus::kNotConverged: return "not-converged";
    case RefineStatus::kZeno: return "zeno";
    case RefineStatus::kJumpCountMismatch: return "jump-count-mismatch";
    case RefineStatus::kSingularFisher: return "singular-fisher";
    case RefineStatus::kResidualRms: return "residual-rms";
    case RefineStatus::kResidualCorrelation: return "residual-correlation";
  }
  return "unknown";
}

bool RefineOptions::IsValid(std::string* error) const {
  auto fail = [&](std::string what) {
    if (error) *error = std::move(what);
    return false;
  };
  if (!sensitivity.IsValid(error)) return false;
  if (!(noise_tolerance > 0.0) || !std::isfinite(noise_tolerance)) {
    return fail(fmt::format("RefineOptions::noise_tolerance = {}: must be finite and > 0", noise_tolerance));
  }
  if (!(polish_tolerance > 0.0) || !std::isfinite(polish_tolerance)) {
    return fail(
        fmt::format("RefineOptions::polish_tolerance = {}: must be finite and > 0", polish_tolerance));
  }
  if (max_iterations < 1) {
    return fail(fmt::format("RefineOptions::max_iterations = {}: must be >= 1", max_iterations));
  }
  if (!(function_tolerance > 0.0) || !(parameter_tolerance > 0.0)) {
    return fail(fmt::format("RefineOptions::function_tolerance = {}, parameter_tolerance = {}: must be > 0",
                            function_tolerance, parameter_tolerance));
  }
  if (!(rms_high > 1.0) || !std::isfinite(rms_high)) {
    return fail(fmt::format("RefineOptions::rms_high = {}: must be finite and > 1", rms_high));
  }
  if (!(rms_low > 0.0) || !(rms_low < 1.0)) {
    return fail(fmt::format("RefineOptions::rms_low = {}: must be in (0, 1)", rms_low));
  }
  if (!(max_lag1 > 0.0) || !(max_lag1 <= 1.0)) {
    return fail(fmt::format("RefineOptions::max_lag1 = {}: must be in (0, 1]", max_lag1));
  }
  if (!(jump_time_tolerance >= 0.0) || !std::isfinite(jump_time_tolerance)) {
    return fail(
        fmt::format("RefineOptions::jump_time_tolerance = {}: must be finite and >= 0", jump_time_tolerance));
  }
  if (max_span_retries < 0) {
    return fail(fmt::format("RefineOptions::max_span_retries = {}: must be >= 0", max_span_retries));
  }
  if (min_jump_interval < 0) {
    return fail(fmt::format("RefineOptions::min_jump_interval = {}: must be >= 0", min_jump_interval));
  }
  if (sigma.size() != 0 && (!sigma.allFinite() || (sigma.array() < 0.0).any())) {
    return fail("RefineOptions::sigma: every entry must be finite and >= 0");
  }
  return true;
}

namespace {

// Everything one evaluation of the cost needs.
struct FitProblem {
  const Model* model = nullptr;
  const Mat* y = nullptr;
  SampleGrid grid;
  std::vector<int> segments;
  Unknowns unknowns;
  HybridParameters start;
  Vec weight;  // 1/σ_i for the residuals
  SensitivityOptions options;
  // Set by the jump checks: the first sample at which the model's jumps and the detected ones
  // disagree (−1: none found), where a shorter span may end.
  mutable long disagreement = -1;

  // The matched trajectory at θ (states only unless `sensitivities`); ok() false when it fails.
  SensitivityTrajectory Simulate(const ConstVecRef& theta, bool sensitivities) const {
    SensitivityOptions o = options;
    o.sensitivities = sensitivities;
    const HybridParameters p = start.WithTheta(unknowns, theta);
    if (!Admissible(*model, p)) return LeftDomain();
    return SimulateSensitivitiesMatched(*model, p, unknowns, grid, segments, o);
  }

  // The last evaluation with sensitivities (Ceres' last accepted point is usually one): reused for
  // the checks at the fit instead of integrating again.
  mutable Vec cached_theta;
  mutable SensitivityTrajectory cached;
  SensitivityTrajectory SimulateCached(const ConstVecRef& theta) const {
    if (cached_theta.size() == theta.size() && cached_theta == theta &&
        cached.trajectory.status.stop == SimStop::kCompleted && cached.sensitivities.cols() == y->cols()) {
      return cached;
    }
    return Simulate(theta, true);
  }
};

class OutputErrorCost final : public ceres::CostFunction {
 public:
  explicit OutputErrorCost(const FitProblem& problem) : problem_(problem) {
    set_num_residuals(static_cast<int>(problem.y->size()));
    mutable_parameter_block_sizes()->push_back(problem.unknowns.size(problem.model->state_size()));
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const int p = parameter_block_sizes()[0];
    const Eigen::Map<const Vec> theta(parameters[0], p);
    const bool jac = jacobians != nullptr && jacobians[0] != nullptr;
    SensitivityTrajectory s = problem_.Simulate(theta, jac);
    if (!s.ok()) return false;
    const Mat& y = *problem_.y;
    const Eigen::Index n = y.rows(), k_count = y.cols();
    Eigen::Map<Mat> r(residuals, n, k_count);
    r = problem_.weight.asDiagonal() * (y - s.trajectory.x);
    if (!r.allFinite()) return false;
    if (jac) {
      // Row-major (n·K) × p: row k·n + i is −S_k(i, :)/σ_i.
      const double* w = problem_.weight.data();
      for (Eigen::Index k = 0; k < k_count; ++k) {
        const double* sk = s.sensitivities.col(k).data();  // n × p, column-major
        double* row = jacobians[0] + k * n * p;
        for (Eigen::Index i = 0; i < n; ++i) {
          for (Eigen::Index c = 0; c < p; ++c) row[i * p + c] = -w[i] * sk[c * n + i];
        }
      }
      problem_.cached_theta = theta;
      problem_.cached = std::move(s);
    }
    return true;
  }

 private:
  const FitProblem& problem_;
};

// First non-finite entry of y, or "" when all are finite.
std::string FirstNonFinite(const Mat& y) {
  for (Eigen::Index k = 0; k < y.cols(); ++k) {
    for (Eigen::Index i = 0; i < y.rows(); ++i) {
      if (!std::isfinite(y(i, k))) return fmt::format("sample {} component {} is {}", k, i + 1, y(i, k));
    }
  }
  return "";
}

// Integration accuracy per component: residuals below 1e3 × this say nothing about the noise.
ceres::Solver::Summary Solve(const FitProblem& problem, const RefineOptions& options, Vec& theta) {
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem cp(po);
  cp.AddResidualBlock(new OutputErrorCost(problem), nullptr, theta.data());
  return SolveLeastSquares(cp, options, ceres::DENSE_NORMAL_CHOLESKY);  // p ≤ a dozen: JᵀJ
}

// The last three jump intervals shrink and the last two are below one sample: the jumps accumulate
// faster than the samples can show (a Zeno approach).
bool AccumulatesWithinASample(const std::vector<JumpRecord>& jumps, double dt) {
  const std::size_t m = jumps.size();
  if (m < 4) return false;
  const double i1 = jumps[m - 1].t - jumps[m - 2].t, i2 = jumps[m - 2].t - jumps[m - 3].t,
               i3 = jumps[m - 3].t - jumps[m - 4].t;
  return i1 < i2 && i2 < i3 && i2 < dt;
}

// The model at p on its own over the span (plain mode, states only).
SensitivityTrajectory SimulatePlain(const FitProblem& problem, const HybridParameters& p) {
  SensitivityOptions o = problem.options;
  o.sensitivities = false;
  return SimulateSensitivities(*problem.model, p, problem.unknowns, problem.grid, o);
}

// The fitted model on its own (plain mode, states only): Zeno, jump count, jump times.
void CheckJumps(const FitProblem& problem, const RefineOptions& options, const HybridParameters& fit,
                RefineResult& r) {
  const SensitivityTrajectory plain = SimulatePlain(problem, fit);
  const SimStatus& st = plain.trajectory.status;
  r.model_jumps = static_cast<int>(plain.trajectory.jumps.size());
  problem.disagreement = FirstDisagreement(plain.trajectory.jumps, problem.segments,
                                           SampleClock{.dt = problem.grid.dt}, options.jump_time_tolerance);
  if (st.stop == SimStop::kZeno) {
    return Fail(r, RefineStatus::kZeno, fmt::format("the fitted model is Zeno: {}", st.message));
  }
  if (!st.completed()) {
    return Fail(r, RefineStatus::kNotConverged,
                fmt::format("the fitted model does not simulate: {}: {}", ToString(st.stop), st.message));
  }
  if (r.model_jumps != r.detected_jumps &&
      AccumulatesWithinASample(plain.trajectory.jumps, problem.grid.dt)) {
    const auto& jumps = plain.trajectory.jumps;
    return Fail(r, RefineStatus::kZeno,
                fmt::format("the fitted model's jumps accumulate (Zeno) near t = {:.6g}: {} jumps, the last "
                            "ones less than a sample apart, against {} detected",
                            jumps.back().t, r.model_jumps, r.detected_jumps));
  }
  if (r.model_jumps != r.detected_jumps) {
    return Fail(r, RefineStatus::kJumpCountMismatch,
                fmt::format("the fitted model jumps {} times, the detector found {}", r.model_jumps,
                            r.detected_jumps));
  }
  const double dt = problem.grid.dt;
  long k = 0;
  for (int j = 0; j < r.model_jumps; ++j) {
    while (problem.segments[static_cast<std::size_t>(k)] <= j) ++k;  // first sample of segment j + 1
    const double t = plain.trajectory.jumps[static_cast<std::size_t>(j)].t;
    const double lo = static_cast<double>(k - 1) * dt, hi = static_cast<double>(k) * dt;
    const double off = t < lo ? (lo - t) / dt : (t > hi ? (t - hi) / dt : 0.0);
    if (off > options.jump_time_tolerance) {
      return Fail(r, RefineStatus::kJumpCountMismatch,
                  fmt::format("fitted jump {} at t = {:.6g} is {:.3g} samples from the detected "
                              "interval ({:.6g}, {:.6g}]",
                              j + 1, t, off, lo, hi));
    }
  }
}

// σ, covariance, normalised RMS and lag-1 autocorrelation from the residuals at the fit.
void CheckResiduals(const FitProblem& problem, const RefineOptions& options, const SensitivityTrajectory& s,
                    const Vec& mad_sigma, RefineResult& r) {
  const Mat& y = *problem.y;
  const Eigen::Index n = y.rows(), k_count = y.cols(), p = s.parameters;
  const Mat res = y - s.trajectory.x;
  const double dof = static_cast<double>(k_count) - static_cast<double>(p) / static_cast<double>(n);
  const Vec sigma_hat = (res.rowwise().squaredNorm() / dof).cwiseSqrt();
  const Vec floor = NumericalFloor(y, problem.options.sim);
  r.sigma_estimated = options.sigma.size() == 0;
  r.sigma = r.sigma_estimated ? sigma_hat : options.sigma;
  r.sigma = r.sigma.cwiseMax(1e-3 * floor);  // noise-free data: the integration accuracy
  const Crlb bound = CrlbFromFisher(FisherInformation(s, r.sigma), problem.unknowns, r.names);
  if (!bound.ok()) return Fail(r, RefineStatus::kSingularFisher, bound.message);
  r.covariance = bound.covariance;
  r.standard_errors = bound.sd;
  const Mat z = r.sigma.cwiseInverse().asDiagonal() * res;
  const double lag = (z.leftCols(k_count - 1).array() * z.rightCols(k_count - 1).array()).sum();
  JudgeResiduals(z, lag, sigma_hat, mad_sigma, floor, options, r);
}

void CheckInputs(const Model& model, const Mat& y, double dt, const Vec& alpha0, const Vec& beta0,
                 const std::vector<std::uint8_t>& gamma, const RefineOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument(error);
  if (y.rows() != model.state_size()) {
    throw std::invalid_argument(fmt::format("Refine: y has {} rows; model '{}' has {} states", y.rows(),
                                            model.name(), model.state_size()));
  }
  if (alpha0.size() != model.alpha_size() || beta0.size() != model.beta_size()) {
    throw std::invalid_argument("Refine: alpha0/beta0 must be the model's full parameter vectors");
  }
  if (static_cast<Eigen::Index>(gamma.size()) != y.cols()) {
    throw std::invalid_argument(
        fmt::format("Refine: gamma has {} entries for {} samples", gamma.size(), y.cols()));
  }
  if (!(dt > 0.0) || !std::isfinite(dt))
    throw std::invalid_argument(fmt::format("Refine: dt = {}: must be > 0", dt));
  if (options.sigma.size() != 0 && options.sigma.size() != model.state_size()) {
    throw std::invalid_argument(fmt::format("RefineOptions::sigma has {} entries; the model has {} states",
                                            options.sigma.size(), model.state_size()));
  }
}

// The refinement after the input checks: start, solve, checks.
void RunRefinement(FitProblem& problem, const RefineOptions& options, const Vec& mad_sigma, RefineResult& r) {
  Vec theta = r.start.Theta(r.unknowns);
  const SensitivityTrajectory at_start = problem.Simulate(theta, false);
  if (!at_start.ok()) {
    // The start's jump times drift from the data (it is not fit yet): only its jump count is compared.
    const SensitivityTrajectory plain = SimulatePlain(problem, r.start);
    problem.disagreement =
        FirstDisagreement(plain.trajectory.jumps, problem.segments, SampleClock{.dt = problem.grid.dt},
                          std::numeric_limits<double>::infinity());
    return Fail(r, RefineStatus::kStartFailed,
                fmt::format("the start does not simulate on the detected segments: {}",
                            at_start.trajectory.status.message));
  }
  const ceres::Solver::Summary summary = Solve(problem, options, theta);
  r.iterations = static_cast<int>(summary.iterations.size());
  r.initial_cost = summary.initial_cost;
  r.final_cost = summary.final_cost;
  if (summary.termination_type != ceres::CONVERGENCE || !theta.allFinite()) {
    return Fail(r, RefineStatus::kNotConverged, fmt::format("Ceres: {}", summary.message));
  }
  // Residuals at the integration accuracy (noise-free data): polish at the tighter tolerances.
  const SensitivityTrajectory at_fit = problem.SimulateCached(theta);
  if (at_fit.ok() && options.polish_tolerance < problem.options.sim.rtol) {
    const Vec sigma_hat =
        ((*problem.y - at_fit.trajectory.x).rowwise().squaredNorm() / static_cast<double>(problem.y->cols()))
            .cwiseSqrt();
    if ((sigma_hat.array() < NumericalFloor(*problem.y, problem.options.sim).array()).all()) {
      problem.options.sim.rtol = problem.options.sim.atol = options.polish_tolerance;
      const ceres::Solver::Summary polish = Solve(problem, options, theta);
      r.iterations += static_cast<int>(polish.iterations.size());
      r.final_cost = polish.final_cost;
      if (polish.termination_type != ceres::CONVERGENCE || !theta.allFinite()) {
        return Fail(r, RefineStatus::kNotConverged, fmt::format("Ceres (polish): {}", polish.message));
      }
    }
  }
  r.refined = r.start.WithTheta(r.unknowns, theta);
  const SensitivityTrajectory s = problem.SimulateCached(theta);
  if (!s.ok()) {
    return Fail(r, RefineStatus::kNotConverged,
                fmt::format("the fit does not simulate: {}", s.trajectory.status.message));
  }
  CheckJumps(problem, options, r.refined, r);
  if (r.ok()) CheckResiduals(problem, options, s, mad_sigma, r);
}

// Returns the first sample at which the model's jumps and the detected ones disagree (−1: none).
long FitSamples(const Model& model, const Mat& y, double dt, const std::vector<std::uint8_t>& gamma,
                const RefineOptions& options, RefineResult& r) {
  FitProblem problem;
  problem.model = &model;
  problem.y = &y;
  problem.grid = SampleGrid{.t_end = static_cast<double>(y.cols() - 1) * dt, .dt = dt};
  problem.segments.resize(gamma.size());
  int j = 0;
  for (std::size_t k = 0; k < gamma.size(); ++k) problem.segments[k] = j += (k > 0 && gamma[k] != 0);
  problem.unknowns = r.unknowns;
  problem.start = r.start;
  const Vec mad_sigma = EstimateNoiseSigma(y);
  FitWeighting(y, options, mad_sigma, &problem.options, &problem.weight);
  RunRefinement(problem, options, mad_sigma, r);
  return problem.disagreement;
}

// Fits the first `used` samples; false (r untouched but its status) when they are too few.
long FitPrefix(const Model& model, const Mat& y, double dt, const std::vector<std::uint8_t>& gamma, long used,
               const RefineOptions& options, RefineResult& r) {
  r.samples_used = used;
  r.detected_jumps = 0;
  for (long k = 1; k < used; ++k) r.detected_jumps += gamma[static_cast<std::size_t>(k)] != 0;
  const Mat y_used = y.leftCols(used);
  const std::vector<std::uint8_t> gamma_used(gamma.begin(), gamma.begin() + used);
  return FitSamples(model, y_used, dt, gamma_used, options, r);
}

// Fits the first `used` samples; when the model's jumps and the detector's disagree (a missed small
// bounce, a start that jumps once less than the data show), the span is cut to end a margin before the
// first disagreement and fit again.
void FitWithRetries(const Model& model, const Mat& y, double dt, const std::vector<std::uint8_t>& gamma,
                    long used, int p, const RefineOptions& options, RefineResult& r) {
  long cut = FitPrefix(model, y, dt, gamma, used, options, r);
  const long margin = SpanMargin(options);
  for (int retry = 0; retry < options.max_span_retries && SpanRetryable(r.status); ++retry) {
    const long shorter = cut - margin;
    if (cut < 0 || shorter >= used || shorter < p + 2) break;
    const RefineResult failed = r;
    r.status = RefineStatus::kOk;
    r.reason.clear();
    r.refined = r.start;
    r.model_jumps = -1;
    r.iterations = 0;
    r.span_reason = SpanRetryReason(used, failed.status, cut);
    used = shorter;
    cut = FitPrefix(model, y, dt, gamma, used, options, r);
    if (!r.ok() && !SpanRetryable(r.status)) {
      r = failed;  // the shorter span fails for another reason: the first failure is reported
      break;
    }
  }
}

// The span of the fit (FitLength) and its reason; false (status too-few-samples) when too short.
bool FitSpan(const std::vector<std::uint8_t>& gamma, int p, const RefineOptions& options, RefineResult& r,
             long* used) {
  *used = FitLength(gamma, options.min_jump_interval);
  if (*used < static_cast<long>(gamma.size())) {
    r.span_reason = CloseJumpsReason(options);
  }
  if (*used >= p + 2) return true;
  r.samples_used = *used;
  Fail(r, RefineStatus::kTooFewSamples,
       fmt::format("{} samples before the detected jumps come closer than {} samples, for {} unknowns", *used,
                   options.min_jump_interval, p));
  return false;
}

// After a failed fit from the recursive estimate, or one that is ok on a span shortened by the
// retries: the fit from a repaired start (RepairStart). Its result replaces r when it is ok (and, r
// ok, fits more samples); else r is kept, and when r is not ok its reason says how the second
// attempt ended.
void FitFromRepairedStart(const Model& model, const Mat& y, double dt, const std::vector<std::uint8_t>& gamma,
                          int p, const RefineOptions& options, RefineResult& r) {
  if (r.status == RefineStatus::kNonFiniteData || r.status == RefineStatus::kTooFewSamples) return;
  SensitivityOptions sens;
  Vec weight;
  FitWeighting(y, options, EstimateNoiseSigma(y), &sens, &weight);
  const StartRepair repair =
      RepairStart(model, y, dt, gamma, r.start, r.unknowns, weight, sens, options.start_repair);
  if (!repair.ok) return;
  RefineResult second;
  second.unknowns = r.unknowns;
  second.names = r.names;
  second.start = repair.start;
  second.refined = repair.start;
  long used = 0;
  if (FitSpan(repair.gamma, p, options, second, &used)) {
    FitWithRetries(model, y, dt, repair.gamma, used, p, options, second);
  }
  AdoptRepaired(r, std::move(second), repair.Summary());
}

}  // namespace

RefineResult Refine(const Model& model, const Mat& y, double dt, const Vec& alpha0, const Vec& beta0,
                    const std::vector<std::uint8_t>& gamma, const RefineOptions& options) {
  CheckInputs(model, y, dt, alpha0, beta0, gamma, options);
  RefineResult r;
  r.unknowns = Unknowns::Of(model);
  r.names = r.unknowns.Names(model);
  // No sample to start from: the status below, never a read of y.col(0).
  const Vec first = y.cols() > 0 ? Vec(y.col(0)) : Vec::Zero(model.state_size()).eval();
  r.start = HybridParameters{alpha0, beta0, first};
  r.refined = r.start;
  r.estimate = r.start;
  const int n = model.state_size(), p = r.unknowns.size(n);
  for (std::size_t k = 1; k < gamma.size(); ++k) r.detected_jumps += gamma[k] != 0;
  if (const std::string bad = FirstNonFinite(y); !bad.empty()) {
    Fail(r, RefineStatus::kNonFiniteData, fmt::format("the data are not finite: {}", bad));
    return r;
  }
  if (!alpha0.allFinite() || !beta0.allFinite()) {
    Fail(r, RefineStatus::kStartFailed, "the recursive estimate is not finite");
    return r;
  }
  if (y.cols() < p + 2) {
    Fail(r, RefineStatus::kTooFewSamples, fmt::format("{} samples for {} unknowns", y.cols(), p));
    return r;
  }
  long used = 0;
  if (!FitSpan(gamma, p, options, r, &used)) return r;
  FitWithRetries(model, y, dt, gamma, used, p, options, r);
  // Not ok, or ok only on a span cut short by the retries: the repaired start may fit more.
  if ((!r.ok() || r.samples_used < used) && options.repair_start) {
    FitFromRepairedStart(model, y, dt, gamma, p, options, r);
  }
  Conclude(r);
  return r;
}

RefineResult RefineIdentification(const Model& model, const Mat& y, double dt,
                                  const IdentifyResult& recursive, const RefineOptions& options) {
  return Refine(model, y, dt, recursive.alpha_hat, recursive.beta_hat, recursive.gamma, options);
}

ceres::Solver::Summary SolveLeastSquares(ceres::Problem& problem, const RefineOptions& options,
                                         ceres::LinearSolverType linear_solver) {
  ceres::Solver::Options so;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.linear_solver_type = linear_solver;
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = options.function_tolerance;
  so.parameter_tolerance = options.parameter_tolerance;
  so.gradient_tolerance = 1e-16;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  so.num_threads = 1;
  // Ceres reports a failed evaluation through glog as well; the status carries it here.
  static const bool quiet = [] {
    FLAGS_minloglevel = google::GLOG_FATAL;
    return true;
  }();
  (void)quiet;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  return summary;
}

Vec NumericalFloor(const Mat& y, const SimOptions& sim) {
  return (1e3 * (sim.rtol * y.cwiseAbs().rowwise().maxCoeff().array() + sim.atol)).matrix();
}

// The CVODE steps one simulation of a fit may take per sample (the budget is also capped by
// RefineOptions::sensitivity.sim.max_steps).
constexpr long kMaxStepsPerSample = 1000;

void FitWeighting(const Mat& y, const RefineOptions& options, const Vec& mad_sigma, SensitivityOptions* sens,
                  Vec* weight) {
  const Vec weighting = options.sigma.size() ? options.sigma : mad_sigma;
  *sens = options.sensitivity;
  const double scale = std::max(1.0, y.cwiseAbs().maxCoeff());
  const double tolerance = std::clamp(options.noise_tolerance * weighting.minCoeff() / scale,
                                      std::min(options.polish_tolerance, options.sensitivity.sim.rtol),
                                      options.sensitivity.sim.rtol);
  sens->sim.rtol = sens->sim.atol = tolerance;
  // The work of one simulation grows with the data, not without bound: a trial point whose flow
  // needs more than kMaxStepsPerSample CVODE steps per sample is far from data sampled that coarsely
  // (δt longer than the time between jumps made a fit take a minute); its evaluation fails and
  // Ceres steps back.
  sens->sim.max_steps = std::min(sens->sim.max_steps, kMaxStepsPerSample * static_cast<long>(y.cols()));
  *weight = weighting.cwiseMax(1e-3 * NumericalFloor(y, sens->sim)).cwiseInverse();
}

void Fail(RefineResult& r, RefineStatus status, std::string reason) {
  r.status = status;
  r.reason = std::move(reason);
}

void Conclude(RefineResult& r) {
  if (r.ok()) {
    r.estimate = r.refined;
  } else {
    r.covariance.resize(0, 0);
    r.standard_errors.resize(0);
  }
}

void JudgeResiduals(const Mat& z, double lag, const Vec& sigma_hat, const Vec& mad_sigma, const Vec& floor,
                    const RefineOptions& options, RefineResult& r) {
  r.normalized_rms = 0.0;
  if (r.sigma_estimated) {
    for (Eigen::Index i = 0; i < sigma_hat.size(); ++i) {
      if (mad_sigma[i] > floor[i]) r.normalized_rms = std::max(r.normalized_rms, sigma_hat[i] / mad_sigma[i]);
    }
  } else {
    r.normalized_rms = std::sqrt(z.squaredNorm() / static_cast<double>(z.size()));
  }
  r.lag1 = z.squaredNorm() > 0.0 ? lag / z.squaredNorm() : 0.0;
  const bool above_floor = (sigma_hat.array() > floor.array()).all();
  if (r.normalized_rms > options.rms_high ||
      (!r.sigma_estimated && above_floor && r.normalized_rms < options.rms_low)) {
    return Fail(r, RefineStatus::kResidualRms,
                fmt::format("normalised residual RMS {:.4g} outside [{:g}, {:g}]{}", r.normalized_rms,
                            r.sigma_estimated ? 0.0 : options.rms_low, options.rms_high,
                            r.sigma_estimated ? " (residual sigma over the MAD estimate)" : ""));
  }
  if (above_floor && std::abs(r.lag1) > options.max_lag1) {
    return Fail(r, RefineStatus::kResidualCorrelation,
                fmt::format("lag-1 autocorrelation of the residuals {:.4g} (|.| > {:g}): the model or "
                            "the detected jumps do not fit the data",
                            r.lag1, options.max_lag1));
  }
}

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

bool Admissible(const Model& model, const HybridParameters& p) {
  return p.alpha.allFinite() && p.beta.allFinite() && p.x0.allFinite() &&
         (model.InFlowSet(p.x0) || model.InJumpSet(p.x0));
}

SensitivityTrajectory LeftDomain() {
  SensitivityTrajectory bad;
  bad.trajectory.status.stop = SimStop::kLeftDomain;
  bad.trajectory.status.message = "x0 outside C and D, or parameters not finite";
  return bad;
}

}  // namespace hysid
