// RefineChains: the output-error refinement of several chains of samples at their own times, α and β
// shared, one initial state per chain (sim/refine/refine.hpp).
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <ceres/ceres.h>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/model/noise_shape.hpp"
#include "sim/refine/refine.hpp"
#include "sim/refine/solve.hpp"
#include "sim/refine/span.hpp"

namespace hysid {
namespace {

// What one fit of the chains starts from.
struct ChainsStart {
  HybridParameters start;  // α, β (x0: chain 1's start; the fit reports its first chain's)
  std::vector<std::vector<std::uint8_t>> gamma;  // per chain: its jump labels
  std::vector<Vec> x0;                           // per chain: its initial state's start
  std::vector<long> limit;                       // per chain: the samples the span retries leave
  std::vector<std::string> reason;               // per chain: why the retries cut it ("" when not)
};

// The chain whose failure the span retries may mend, and its first sample at which the model's jumps
// and the detected ones disagree (−1: none).
struct ChainFailure {
  long chain = -1;  // in the caller's list
  long disagreement = -1;
};

// One chain as fit: the span used, its times from 0, its detected segments.
struct ChainFit {
  long index = 0;  // in the caller's list
  std::vector<double> times;
  Mat y;
  std::vector<int> segments;
  Vec x0;
};

struct ChainsProblem {
  const Model* model = nullptr;
  Unknowns unknowns;  // α, β and x0: the sensitivity layout of one chain
  HybridParameters start;
  std::vector<ChainFit> fits;
  Vec weight;  // 1/σ_i
  SensitivityOptions options;
  int shared = 0;  // |α_u| + |β_u|
  ChainFailure failure;

  HybridParameters At(const double* theta, const double* x0) const {
    Vec full(shared + model->state_size());
    full.head(shared) = Eigen::Map<const Vec>(theta, shared);
    full.tail(model->state_size()) = Eigen::Map<const Vec>(x0, model->state_size());
    return start.WithTheta(unknowns, full);
  }

  SensitivityTrajectory Simulate(const ChainFit& c, const double* theta, const double* x0, bool sens) const {
    const HybridParameters p = At(theta, x0);
    if (!Admissible(*model, p)) return LeftDomain();
    SensitivityOptions o = options;
    o.sensitivities = sens;
    return SimulateSensitivitiesMatched(*model, p, unknowns, c.times, c.segments, o);
  }
};

class ChainCost final : public ceres::CostFunction {
 public:
  ChainCost(const ChainsProblem& problem, const ChainFit& chain) : problem_(problem), chain_(chain) {
    set_num_residuals(static_cast<int>(chain.y.size()));
    mutable_parameter_block_sizes()->push_back(problem.shared);
    mutable_parameter_block_sizes()->push_back(problem.model->state_size());
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const bool jac = jacobians != nullptr && (jacobians[0] != nullptr || jacobians[1] != nullptr);
    const SensitivityTrajectory s = problem_.Simulate(chain_, parameters[0], parameters[1], jac);
    if (!s.ok()) return false;
    const Eigen::Index n = chain_.y.rows(), k_count = chain_.y.cols();
    Eigen::Map<Mat> r(residuals, n, k_count);
    r = problem_.weight.asDiagonal() * (chain_.y - s.trajectory.x);
    if (!r.allFinite()) return false;
    if (!jac) return true;
    const int shared = problem_.shared, p = s.parameters;
    const double* w = problem_.weight.data();
    for (Eigen::Index k = 0; k < k_count; ++k) {
      const double* sk = s.sensitivities.col(k).data();  // n × p, column-major
      for (Eigen::Index i = 0; i < n; ++i) {
        const Eigen::Index row = k * n + i;
        if (jacobians[0] != nullptr) {
          for (int c = 0; c < shared; ++c) jacobians[0][row * shared + c] = -w[i] * sk[c * n + i];
        }
        if (jacobians[1] != nullptr) {
          for (int c = shared; c < p; ++c) jacobians[1][row * n + (c - shared)] = -w[i] * sk[c * n + i];
        }
      }
    }
    return true;
  }

 private:
  const ChainsProblem& problem_;
  const ChainFit& chain_;
};

void CheckChainInput(const Model& model, const RefineChain& c, std::size_t index) {
  if (c.y.rows() != model.state_size() || static_cast<Eigen::Index>(c.t.size()) != c.y.cols() ||
      c.gamma.size() != c.t.size()) {
    throw std::invalid_argument(fmt::format(
        "RefineChains: chain {}: y is {} × {}, {} times, {} gamma entries; "
        "model '{}' has {} states",
        index + 1, c.y.rows(), c.y.cols(), c.t.size(), c.gamma.size(), model.name(), model.state_size()));
  }
  for (std::size_t k = 1; k < c.t.size(); ++k) {
    if (!(c.t[k] > c.t[k - 1]) || !std::isfinite(c.t[k])) {
      throw std::invalid_argument(fmt::format("RefineChains: chain {}: time {} after {}: must increase",
                                              index + 1, c.t[k], c.t[k - 1]));
    }
  }
}

// Why chain `in` is left out ("" when it is fit), its span `used`.
std::string LeftOut(const Model& model, const RefineChain& in, long used) {
  const int n = model.state_size();
  if (used < 2 * n + 2) return fmt::format("left out: {} samples to fit, fewer than {}", used, 2 * n + 2);
  if (!in.y.leftCols(used).allFinite()) return "left out: samples not finite";
  if (!model.InFlowSet(in.y.col(0)) && !model.InJumpSet(in.y.col(0))) {
    return "left out: the first sample lies outside C and D";
  }
  return "";
}

// The chains as fit from s: span rule and retry limits, too short or outside C ∪ D left out; each
// chain's samples and span reason in r.
std::vector<ChainFit> PrepareChains(const Model& model, const std::vector<RefineChain>& chains,
                                    const ChainsStart& s, const RefineOptions& options, RefineResult& r) {
  std::vector<ChainFit> fits;
  r.chain_x0.assign(chains.size(), Vec());
  r.chain_samples_used.assign(chains.size(), 0);
  r.chain_span_reason.assign(chains.size(), "");
  for (std::size_t c = 0; c < chains.size(); ++c) {
    const RefineChain& in = chains[c];
    const long whole = FitLength(s.gamma[c], options.min_jump_interval), used = std::min(whole, s.limit[c]);
    r.chain_span_reason[c] =
        used < whole ? s.reason[c] : (whole < in.y.cols() ? CloseJumpsReason(options) : "");
    if (const std::string out = LeftOut(model, in, used); !out.empty()) {
      r.chain_span_reason[c] = out;
      ++r.chains_skipped;
      continue;
    }
    ChainFit f;
    f.index = static_cast<long>(c);
    f.y = in.y.leftCols(used);
    f.x0 = s.x0[c];
    int j = 0;
    for (long k = 0; k < used; ++k) {
      const auto u = static_cast<std::size_t>(k);
      f.times.push_back(in.t[u] - in.t[0]);
      j += (k > 0 && s.gamma[c][u] != 0) ? 1 : 0;
      f.segments.push_back(j);
    }
    r.detected_jumps += j;
    r.samples_used += used;
    r.chain_samples_used[c] = used;
    fits.push_back(std::move(f));
  }
  r.chains_used = static_cast<long>(fits.size());
  for (std::size_t c = 0; c < chains.size(); ++c) {
    if (r.chain_span_reason[c].empty()) continue;
    r.span_reason +=
        fmt::format("{}chain {}: {}", r.span_reason.empty() ? "" : "; ", c + 1, r.chain_span_reason[c]);
  }
  return fits;
}

// The samples of the chains side by side (Part: ChainFit or RefineChain).
template <class Part>
Mat Concatenated(const std::vector<Part>& fits, int n) {
  Eigen::Index k = 0;
  for (const Part& f : fits) k += f.y.cols();
  Mat all(n, k);
  k = 0;
  for (const Part& f : fits) {
    all.middleCols(k, f.y.cols()) = f.y;
    k += f.y.cols();
  }
  return all;
}

// Integration accuracy per component: residuals below 1e3 × this say nothing about the noise.
ceres::Solver::Summary SolveChains(const ChainsProblem& problem, const RefineOptions& options, Vec& theta,
                                   std::vector<Vec>& x0) {
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem cp(po);
  for (std::size_t c = 0; c < problem.fits.size(); ++c) {
    cp.AddResidualBlock(new ChainCost(problem, problem.fits[c]), nullptr, theta.data(), x0[c].data());
  }
  return SolveLeastSquares(cp, options, ceres::DENSE_SCHUR);  // the chains' x0 blocks eliminated
}

// Chain f's jumps at the fit (matched mode) against its detected intervals: Zeno, count, times.
void CheckChainJumps(const ChainFit& f, const SensitivityTrajectory& s, const RefineOptions& options,
                     RefineResult& r) {
  const SimStatus& st = s.trajectory.status;
  const long chain = f.index + 1;
  if (st.stop == SimStop::kZeno) {
    return Fail(r, RefineStatus::kZeno,
                fmt::format("chain {}: the fitted model is Zeno: {}", chain, st.message));
  }
  if (s.extra_jumps > 0) {
    return Fail(
        r, RefineStatus::kJumpCountMismatch,
        fmt::format("chain {}: the fitted model jumps {} more times than detected", chain, s.extra_jumps));
  }
  std::size_t j = 0;
  for (std::size_t k = 1; k < f.segments.size() && j < s.trajectory.jumps.size(); ++k) {
    if (f.segments[k] == f.segments[k - 1]) continue;
    const double lo = f.times[k - 1], hi = f.times[k], t = s.trajectory.jumps[j++].t;
    const double off = (t < lo ? lo - t : (t > hi ? t - hi : 0.0)) / (hi - lo);
    if (off > options.jump_time_tolerance) {
      return Fail(r, RefineStatus::kJumpCountMismatch,
                  fmt::format("chain {}: fitted jump {} at t = {:.6g} is {:.3g} samples from the detected "
                              "interval ({:.6g}, {:.6g}] (chain times from 0)",
                              chain, j, t, off, lo, hi));
    }
  }
}

// The names of the joint θ: the shared unknowns, then x0 of each fitted chain.
std::vector<std::string> JointNames(const Model& model, const ChainsProblem& problem) {
  Unknowns shared = problem.unknowns;
  shared.x0 = false;
  std::vector<std::string> names = shared.Names(model);
  const std::vector<std::string> all = problem.unknowns.Names(model);
  for (const ChainFit& f : problem.fits) {
    for (int i = 0; i < model.state_size(); ++i) {
      names.push_back(
          fmt::format("{} chain {}", all[static_cast<std::size_t>(problem.shared + i)], f.index + 1));
    }
  }
  return names;
}

// The joint Fisher information: shared block plus one x0 block per chain.
Mat JointFisher(const ChainsProblem& problem, const std::vector<SensitivityTrajectory>& sims,
                const Vec& sigma) {
  const int s = problem.shared, n = problem.model->state_size();
  const auto total = static_cast<Eigen::Index>(s + n * static_cast<int>(sims.size()));
  Mat f = Mat::Zero(total, total);
  for (std::size_t c = 0; c < sims.size(); ++c) {
    const Mat fc = FisherInformation(sims[c], sigma);
    const auto o = static_cast<Eigen::Index>(s + n * static_cast<int>(c));
    f.topLeftCorner(s, s) += fc.topLeftCorner(s, s);
    f.block(0, o, s, n) = fc.topRightCorner(s, n);
    f.block(o, 0, n, s) = fc.bottomLeftCorner(n, s);
    f.block(o, o, n, n) = fc.bottomRightCorner(n, n);
  }
  return f;
}

// σ, the covariance of the shared unknowns, normalised RMS and lag-1 (within chains), pooled.
void CheckPooled(const Model& model, const ChainsProblem& problem,
                 const std::vector<SensitivityTrajectory>& sims, const Vec& mad_sigma,
                 const RefineOptions& options, RefineResult& r) {
  const int n = model.state_size();
  const Mat y = Concatenated(problem.fits, n);
  Mat res(n, y.cols());
  Eigen::Index k = 0;
  for (std::size_t c = 0; c < sims.size(); ++c) {
    res.middleCols(k, problem.fits[c].y.cols()) = problem.fits[c].y - sims[c].trajectory.x;
    k += problem.fits[c].y.cols();
  }
  const double p = problem.shared + n * static_cast<double>(sims.size());
  const Vec sigma_hat = (res.rowwise().squaredNorm() / (static_cast<double>(y.cols()) - p / n)).cwiseSqrt();
  const Vec floor = NumericalFloor(y, problem.options.sim);
  r.sigma_estimated = options.sigma.size() == 0;
  r.sigma = (r.sigma_estimated ? sigma_hat : options.sigma).cwiseMax(1e-3 * floor);
  const Crlb bound =
      CrlbFromFisher(JointFisher(problem, sims, r.sigma), problem.unknowns, JointNames(model, problem));
  if (!bound.ok()) return Fail(r, RefineStatus::kSingularFisher, bound.message);
  r.covariance = bound.covariance.topLeftCorner(problem.shared, problem.shared);
  r.standard_errors = bound.sd.head(problem.shared);
  const Mat z = r.sigma.cwiseInverse().asDiagonal() * res;
  double lag = 0.0;
  k = 0;
  for (const ChainFit& f : problem.fits) {
    const Eigen::Index m = f.y.cols();
    lag += (z.middleCols(k, m - 1).array() * z.middleCols(k + 1, m - 1).array()).sum();
    k += m;
  }
  JudgeResiduals(z, lag, sigma_hat, mad_sigma, floor, options, r);
}

// Each chain simulated at (theta, x0); false with kStartFailed / kNotConverged naming the chain.
bool SimulateAll(const ChainsProblem& problem, const Vec& theta, const std::vector<Vec>& x0, bool sens,
                 RefineStatus failure, const char* what, std::vector<SensitivityTrajectory>* sims,
                 RefineResult& r) {
  sims->clear();
  for (std::size_t c = 0; c < problem.fits.size(); ++c) {
    sims->push_back(problem.Simulate(problem.fits[c], theta.data(), x0[c].data(), sens));
    if (!sims->back().ok()) {
      Fail(r, failure,
           fmt::format("{} chain {}: {}", what, problem.fits[c].index + 1,
                       sims->back().trajectory.status.message));
      return false;
    }
  }
  return true;
}

// A Ceres solve from (theta, x0), then each chain simulated with sensitivities at the fit. Adds the
// iterations to r, sets its final cost (and *initial_cost when given); false with kNotConverged
// ("LABEL: Ceres' message") or the chain that does not simulate.
bool SolveAndSimulate(const ChainsProblem& problem, const RefineOptions& options, const char* label,
                      Vec& theta, std::vector<Vec>& x0, std::vector<SensitivityTrajectory>* sims,
                      RefineResult& r, double* initial_cost = nullptr) {
  const ceres::Solver::Summary summary = SolveChains(problem, options, theta, x0);
  r.iterations += static_cast<int>(summary.iterations.size());
  if (initial_cost) *initial_cost = summary.initial_cost;
  r.final_cost = summary.final_cost;
  if (summary.termination_type != ceres::CONVERGENCE || !theta.allFinite()) {
    Fail(r, RefineStatus::kNotConverged, fmt::format("{}: {}", label, summary.message));
    return false;
  }
  return SimulateAll(problem, theta, x0, true, RefineStatus::kNotConverged, "the fit does not simulate on",
                     sims, r);
}

// The failure of fit c (chain f's model at p on its own over its span, plain mode, states only): the
// first sample at which its jumps and the chain's detected ones disagree by more than `tolerance`
// samples (Refine's rule), for the span retries.
void NoteFailure(ChainsProblem& problem, std::size_t c, const HybridParameters& p, double tolerance) {
  const ChainFit& f = problem.fits[c];
  problem.failure = ChainFailure{.chain = f.index};
  if (!Admissible(*problem.model, p)) return;
  SensitivityOptions o = problem.options;
  o.sensitivities = false;
  const double t_end = f.times.back();
  const SampleGrid grid{t_end, t_end / static_cast<double>(f.times.size() - 1)};
  const SensitivityTrajectory plain = SimulateSensitivities(*problem.model, p, problem.unknowns, grid, o);
  problem.failure.disagreement =
      FirstDisagreement(plain.trajectory.jumps, f.segments, SampleClock{.times = &f.times}, tolerance);
}

// Solve, polish for noise-free data, then the checks at the fit.
void RunChains(const Model& model, ChainsProblem& problem, const RefineOptions& options, const Vec& mad_sigma,
               RefineResult& r) {
  Vec theta = r.start.Theta(Unknowns{problem.unknowns.alpha, problem.unknowns.beta, false});
  std::vector<Vec> x0;
  for (const ChainFit& f : problem.fits) x0.push_back(f.x0);
  std::vector<SensitivityTrajectory> sims;
  if (!SimulateAll(problem, theta, x0, false, RefineStatus::kStartFailed,
                   "the recursive estimate does not simulate on the detected segments of", &sims, r)) {
    // The start's jump times drift from the data (it is not fit yet): only its jump count is compared.
    const std::size_t c = sims.size() - 1;
    return NoteFailure(problem, c, problem.At(theta.data(), x0[c].data()),
                       std::numeric_limits<double>::infinity());
  }
  r.iterations = 0;
  if (!SolveAndSimulate(problem, options, "Ceres", theta, x0, &sims, r, &r.initial_cost)) return;
  const Mat y = Concatenated(problem.fits, model.state_size());
  double sq = 0.0;
  for (std::size_t c = 0; c < sims.size(); ++c)
    sq += (problem.fits[c].y - sims[c].trajectory.x).squaredNorm();
  if (options.polish_tolerance < problem.options.sim.rtol &&
      std::sqrt(sq / static_cast<double>(y.size())) < NumericalFloor(y, problem.options.sim).minCoeff()) {
    problem.options.sim.rtol = problem.options.sim.atol = options.polish_tolerance;
    if (!SolveAndSimulate(problem, options, "Ceres (polish)", theta, x0, &sims, r)) return;
  }
  r.refined = r.start.WithTheta(Unknowns{problem.unknowns.alpha, problem.unknowns.beta, false}, theta);
  r.refined.x0 = x0.front();
  r.model_jumps = 0;
  for (std::size_t c = 0; c < sims.size(); ++c) {
    r.chain_x0[static_cast<std::size_t>(problem.fits[c].index)] = x0[c];
    r.model_jumps += static_cast<int>(sims[c].trajectory.jumps.size()) + sims[c].extra_jumps;
    if (!r.ok()) continue;
    CheckChainJumps(problem.fits[c], sims[c], options, r);
    if (!r.ok()) NoteFailure(problem, c, problem.At(theta.data(), x0[c].data()), options.jump_time_tolerance);
  }
  if (r.ok()) CheckPooled(model, problem, sims, mad_sigma, options, r);
}

void CheckChainsInputs(const Model& model, const std::vector<RefineChain>& chains, const Vec& alpha0,
                       const Vec& beta0, const RefineOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument(error);
  if (alpha0.size() != model.alpha_size() || beta0.size() != model.beta_size()) {
    throw std::invalid_argument("RefineChains: alpha0/beta0 must be the model's full parameter vectors");
  }
  if (options.sigma.size() != 0 && options.sigma.size() != model.state_size()) {
    throw std::invalid_argument(fmt::format("RefineOptions::sigma has {} entries; the model has {} states",
                                            options.sigma.size(), model.state_size()));
  }
  for (std::size_t c = 0; c < chains.size(); ++c) CheckChainInput(model, chains[c], c);
}

// One fit of the chains from s: the chains as fit, the start, the solve and the checks. A failure the
// span retries may mend names its chain in *failure.
RefineResult FitChains(const Model& model, const std::vector<RefineChain>& chains, const ChainsStart& s,
                       const RefineOptions& options, ChainFailure* failure) {
  const int n = model.state_size();
  RefineResult r;
  r.unknowns = Unknowns::Of(model, /*with_x0=*/false);
  r.names = r.unknowns.Names(model);
  r.start = r.refined = r.estimate = s.start;
  ChainsProblem problem;
  problem.model = &model;
  problem.unknowns = Unknowns::Of(model, /*with_x0=*/true);
  problem.shared = r.unknowns.size(n);
  problem.fits = PrepareChains(model, chains, s, options, r);
  if (!problem.fits.empty()) r.start.x0 = r.refined.x0 = r.estimate.x0 = problem.fits.front().x0;
  const double p = problem.shared + static_cast<double>(n) * static_cast<double>(problem.fits.size());
  if (problem.fits.empty() || problem.shared == 0 || static_cast<double>(r.samples_used) < p / n + 2) {
    Fail(
        r, RefineStatus::kTooFewSamples,
        fmt::format("{} samples in {} chains ({} left out: fewer than {} samples or a first sample outside C "
                    "and D) for {} unknowns",
                    r.samples_used, r.chains_used, r.chains_skipped, 2 * n + 2, p));
    return r;
  }
  if (!r.start.alpha.allFinite() || !r.start.beta.allFinite()) {
    Fail(r, RefineStatus::kStartFailed, "the recursive estimate is not finite");
    return r;
  }
  const Mat y = Concatenated(problem.fits, n);
  const Vec mad_sigma = EstimateNoiseSigma(y);
  problem.start = r.start;
  FitWeighting(y, options, mad_sigma, &problem.options, &problem.weight);
  RunChains(model, problem, options, mad_sigma, r);
  *failure = problem.failure;
  return r;
}

// The fit from s; while it fails because a chain's model and its detected jumps disagree (a jump the
// detector missed, or one it added), that chain's span is cut to end SpanMargin samples before the
// first disagreement and the chains are fit again, at most max_span_retries times per chain. A retry
// that fails for another reason leaves the failure before it. *first_used: the samples of the first fit.
RefineResult FitChainsWithRetries(const Model& model, const std::vector<RefineChain>& chains, ChainsStart s,
                                  const RefineOptions& options, long* first_used) {
  ChainFailure failure;
  RefineResult r = FitChains(model, chains, s, options, &failure);
  *first_used = r.samples_used;
  std::vector<int> retries(chains.size(), 0);
  const long margin = SpanMargin(options), shortest = 2L * model.state_size() + 2;
  while (SpanRetryable(r.status) && failure.chain >= 0) {
    const auto c = static_cast<std::size_t>(failure.chain);
    const long used = r.chain_samples_used[c], shorter = failure.disagreement - margin;
    if (retries[c] == options.max_span_retries || failure.disagreement < 0 || shorter >= used ||
        shorter < shortest) {
      break;
    }
    ++retries[c];
    s.limit[c] = shorter;
    s.reason[c] = SpanRetryReason(used, r.status, failure.disagreement);
    RefineResult next = FitChains(model, chains, s, options, &failure);
    if (!next.ok() && !SpanRetryable(next.status)) break;  // the failure before this retry is reported
    r = std::move(next);
  }
  return r;
}

// The recursive start: α0, β0, each chain's detected labels and its first sample, all samples allowed.
ChainsStart RecursiveStart(const std::vector<RefineChain>& chains, const Vec& alpha0, const Vec& beta0,
                           int n) {
  auto first = [n](const RefineChain& c) { return c.y.cols() > 0 ? Vec(c.y.col(0)) : Vec::Zero(n).eval(); };
  ChainsStart s;
  s.start = HybridParameters{alpha0, beta0, chains.empty() ? Vec::Zero(n).eval() : first(chains[0])};
  for (const RefineChain& c : chains) {
    s.gamma.push_back(c.gamma);
    s.x0.push_back(first(c));
    s.limit.push_back(c.y.cols());
    s.reason.emplace_back();
  }
  return s;
}

// The rows of one chain's β regression appended to the stacked ones.
void AppendRows(const StartRepair& repair, Mat& rows, Vec& rhs) {
  const Eigen::Index m = rows.rows(), add = repair.jump_rows.rows();
  rows.conservativeResize(m + add, repair.jump_rows.cols());
  rhs.conservativeResize(m + add);
  rows.bottomRows(add) = repair.jump_rows;
  rhs.tail(add) = repair.jump_rhs;
}

// The repaired start of the chains (sim/refine/start.hpp): RepairStart on each chain that can be fit
// (all its samples, read as a grid at the chain's mean step: the repair is only a start, the fit reads
// each sample at its own time) gives that chain's labels and initial state; α stays the recursive α̂,
// β's unknown entries solve all chains' jump regressions stacked. false when the data are not finite
// or no chain is repaired; *summary: the changes summed over the chains, and the chains changed.
bool RepairChains(const Model& model, const std::vector<RefineChain>& chains, const ChainsStart& recursive,
                  const RefineOptions& options, ChainsStart* out, std::string* summary) {
  for (const RefineChain& c : chains) {
    if (!c.y.allFinite()) return false;
  }
  const Mat y = Concatenated(chains, model.state_size());
  SensitivityOptions sens;
  Vec weight;
  FitWeighting(y, options, EstimateNoiseSigma(y), &sens, &weight);
  const Unknowns unknowns = Unknowns::Of(model, /*with_x0=*/true);
  *out = recursive;
  StartRepair total;
  Mat rows(0, static_cast<Eigen::Index>(unknowns.beta.size()));
  Vec rhs(0);
  std::vector<std::size_t> changed;
  for (std::size_t c = 0; c < chains.size(); ++c) {
    const RefineChain& in = chains[c];
    const long k_count = in.y.cols();
    if (!LeftOut(model, in, k_count).empty()) continue;
    const double dt = (in.t.back() - in.t.front()) / static_cast<double>(k_count - 1);
    const HybridParameters from{recursive.start.alpha, recursive.start.beta, in.y.col(0)};
    const StartRepair repair =
        RepairStart(model, in.y, dt, in.gamma, from, unknowns, weight, sens, options.start_repair);
    if (!repair.ok) continue;
    out->gamma[c] = repair.gamma;
    out->x0[c] = repair.start.x0;
    AppendRows(repair, rows, rhs);
    total.dropped += repair.dropped;
    total.moved += repair.moved;
    total.added += repair.added;
    if (repair.dropped + repair.moved + repair.added > 0) changed.push_back(c + 1);
    total.ok = true;
  }
  if (!total.ok) return false;
  out->start.beta = SolveJumpRows(unknowns, rows, rhs, recursive.start.beta);
  *summary = total.Summary();
  if (!changed.empty()) {
    *summary += fmt::format("; detections changed in chain{} {}", changed.size() > 1 ? "s" : "",
                            fmt::join(changed, ", "));
  }
  return true;
}

// After a failed fit from the recursive estimate, or one ok only on spans cut short by the retries:
// the fit (with its own retries) from the repaired start, adopted as Refine adopts its own.
void FitChainsFromRepairedStart(const Model& model, const std::vector<RefineChain>& chains,
                                const ChainsStart& recursive, const RefineOptions& options, RefineResult& r) {
  if (r.status == RefineStatus::kTooFewSamples || !recursive.start.alpha.allFinite() ||
      !recursive.start.beta.allFinite()) {
    return;
  }
  ChainsStart repaired;
  std::string summary;
  if (!RepairChains(model, chains, recursive, options, &repaired, &summary)) return;
  long first_used = 0;
  AdoptRepaired(r, FitChainsWithRetries(model, chains, repaired, options, &first_used), summary);
}

}  // namespace

std::vector<RefineChain> SplitChains(const std::vector<double>& t, const Mat& y,
                                     const std::vector<std::uint8_t>& chain_start,
                                     const std::vector<std::uint8_t>& gamma) {
  const auto k_count = static_cast<std::size_t>(y.cols());
  if (t.size() != k_count || chain_start.size() != k_count || gamma.size() != k_count) {
    throw std::invalid_argument(
        fmt::format("SplitChains: {} samples, {} times, {} chain_start, {} gamma entries", k_count, t.size(),
                    chain_start.size(), gamma.size()));
  }
  std::vector<RefineChain> chains;
  for (std::size_t k = 0; k < k_count;) {
    std::size_t end = k + 1;
    while (end < k_count && !chain_start[end]) ++end;
    RefineChain c;
    c.t.assign(t.begin() + static_cast<long>(k), t.begin() + static_cast<long>(end));
    c.y = y.middleCols(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(end - k));
    c.gamma.assign(gamma.begin() + static_cast<long>(k), gamma.begin() + static_cast<long>(end));
    chains.push_back(std::move(c));
    k = end;
  }
  return chains;
}

RefineResult RefineChains(const Model& model, const std::vector<RefineChain>& chains, const Vec& alpha0,
                          const Vec& beta0, const RefineOptions& options) {
  CheckChainsInputs(model, chains, alpha0, beta0, options);
  const ChainsStart recursive = RecursiveStart(chains, alpha0, beta0, model.state_size());
  long first_used = 0;
  RefineResult r = FitChainsWithRetries(model, chains, recursive, options, &first_used);
  // Not ok, or ok only on spans cut short by the retries: the repaired start may fit more.
  if ((!r.ok() || r.samples_used < first_used) && options.repair_start) {
    FitChainsFromRepairedStart(model, chains, recursive, options, r);
  }
  Conclude(r);
  return r;
}

}  // namespace hysid
