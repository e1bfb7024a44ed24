#include "sim/events/fitted_outputs.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

#include "core/model/automaton.hpp"
#include "sim/input_signal.hpp"
#include "sim/refine/budget.hpp"

namespace hysid {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// [first, end) of every chain of the samples, as SplitChains cuts them.
std::vector<std::pair<long, long>> ChainSpans(const std::vector<std::uint8_t>& chain_start, long samples) {
  std::vector<std::pair<long, long>> out;
  for (long k = 0; k < samples; ++k) {
    if (k > 0 && (chain_start.empty() || chain_start[std::size_t(k)] == 0)) continue;
    if (!out.empty()) out.back().second = k;
    out.emplace_back(k, samples);
  }
  return out;
}

// A span's sample times from its first and its inputs on them (none without input rows).
struct SpanSamples {
  std::vector<double> times;
  InputSignal inputs;
  const InputSignal* inputs_or_null() const { return inputs.empty() ? nullptr : &inputs; }
};

SpanSamples SamplesOf(const std::vector<double>& t, const Mat& u, std::pair<long, long> span) {
  const auto [a, b] = span;
  SpanSamples s;
  for (long k = a; k < b; ++k) s.times.push_back(t[std::size_t(k)] - t[std::size_t(a)]);
  if (u.rows() > 0) {
    s.inputs.times = s.times;
    s.inputs.values = u.middleCols(a, b - a);
  }
  return s;
}

// One chain's run from `params` on its own sample times (with S and ∂t_j/∂θ when `gradients`); a
// start outside C ∪ D (std::invalid_argument) is a run with no samples and that message. With
// `budgeted`, the run has the budget of a run a fit evaluates (BudgetRun): a point no fit has been
// to (the recursive estimate, which may blow up or chatter) stops there, with that reason, instead
// of spending seconds on its way to the simulator's own step limit.
SensitivityTrajectory RunChain(const Model& model, const HybridParameters& params, const Unknowns& unknowns,
                               const std::vector<double>& t, const Mat& u, std::pair<long, long> span,
                               bool gradients, bool budgeted = false) {
  const SpanSamples samples = SamplesOf(t, u, span);
  SensitivityOptions o;
  o.sensitivities = gradients;
  o.sim.rtol = o.sim.atol = 1e-9;
  if (budgeted) BudgetRun(o, static_cast<long>(samples.times.size()));
  try {
    return SimulateSensitivities(model, params, unknowns, samples.times, o, samples.inputs_or_null());
  } catch (const std::invalid_argument& e) {
    SensitivityTrajectory none;
    none.trajectory.status.stop = SimStop::kLeftDomain;
    none.trajectory.status.message = e.what();
    return none;
  }
}

// The fitted run read on the detected segments, as the refinement compares it with the data: sample k
// on the segment of the chain's detected events before it (gamma), each segment's flow continued past
// its jump (SimulateSensitivitiesMatched). Empty when it does not run (the detected events are not the
// model's: more segments than the model reaches).
Mat RunMatched(const Model& model, const HybridParameters& params, const Unknowns& unknowns,
               const std::vector<double>& t, const Mat& u, std::pair<long, long> span,
               const std::vector<std::uint8_t>& gamma) {
  const auto [a, b] = span;
  const SpanSamples samples = SamplesOf(t, u, span);
  std::vector<int> segment;
  for (long k = a; k < b; ++k) segment.push_back(k == a ? 0 : segment.back() + (gamma[std::size_t(k)] != 0 ? 1 : 0));
  SensitivityOptions o;
  o.sensitivities = false;
  o.sim.rtol = o.sim.atol = 1e-9;
  try {
    const SensitivityTrajectory run = SimulateSensitivitiesMatched(model, params, unknowns, samples.times, segment, o,
                                                                   samples.inputs_or_null());
    if (run.ok() && run.trajectory.size() == b - a) return run.trajectory.x;
  } catch (const std::invalid_argument&) {
  }
  return Mat();
}

// The run's samples into columns [a, a + run size) of `x` (and the band into `sd` with C).
void Store(const SensitivityTrajectory& run, long a, const Mat* covariance, Mat* x, Mat* sd) {
  for (long k = 0; k < run.trajectory.size(); ++k) {
    x->col(a + k) = run.trajectory.x.col(k);
    if (covariance == nullptr) continue;
    const Mat S = run.S(k);
    for (Eigen::Index i = 0; i < S.rows(); ++i) {
      (*sd)(i, a + k) = std::sqrt(std::max(0.0, S.row(i).dot(*covariance * S.row(i).transpose())));
    }
  }
}

std::string Stopped(std::size_t c, const SensitivityTrajectory& run, const std::vector<double>& t, long a) {
  const std::string at = run.trajectory.size() > 0
                             ? fmt::format("after t = {:.6g}", t[std::size_t(a + run.trajectory.size() - 1)])
                             : "at its start";
  return fmt::format("chain {}: the run stops {} ({}{}{})", c + 1, at, ToString(run.trajectory.status.stop),
                     run.trajectory.status.message.empty() ? "" : ": ", run.trajectory.status.message);
}

// The recursive estimate's runs into out->recursive.
void RunRecursive(const Model& model, const std::vector<double>& t, const Mat& y, const Mat& u,
                  const IdentifyResult& recursive, const RefineResult& r,
                  const std::vector<std::pair<long, long>>& spans, FittedOutputs* out) {
  for (std::size_t c = 0; c < spans.size(); ++c) {
    const long a = spans[c].first;
    if (spans[c].second - a < 2) continue;
    HybridParameters p = r.start;
    p.x0 = y.col(a);
    p.initial_mode = recursive.mode.empty() ? -1 : recursive.mode[std::size_t(a)];
    const SensitivityTrajectory run = RunChain(model, p, r.unknowns, t, u, spans[c], false, /*budgeted=*/true);
    Store(run, a, nullptr, &out->recursive, nullptr);
    if (run.trajectory.size() < spans[c].second - a && out->recursive_reason.empty())
      out->recursive_reason = Stopped(c, run, t, a);
  }
}

}  // namespace

FittedOutputs RunFittedModel(const Model& model, const std::vector<double>& t, const Mat& y,
                             const std::vector<std::uint8_t>& chain_start, const Mat& u,
                             const IdentifyResult& recursive, const RefineResult& r) {
  const long K = y.cols();
  const int n = model.state_size();
  if (static_cast<long>(t.size()) != K || y.rows() != n || (!chain_start.empty() && static_cast<long>(chain_start.size()) != K) ||
      (u.rows() > 0 && u.cols() != K)) {
    throw std::invalid_argument(fmt::format("RunFittedModel: {} times, y {} × {}, {} chain starts, u with {} columns: "
                                            "the sizes disagree (n = {})",
                                            t.size(), y.rows(), K, chain_start.size(), u.cols(), n));
  }
  FittedOutputs out;
  out.x = out.sd = out.recursive = out.matched = Mat::Constant(n, K, kNaN);
  out.in_fit.assign(std::size_t(K), 0);
  if (ModeCount(model.spec()) > 1) out.mode.assign(std::size_t(K), -1);
  const std::vector<std::pair<long, long>> spans = ChainSpans(chain_start, K);
  RunRecursive(model, t, y, u, recursive, r, spans, &out);
  if (!r.reported) {
    out.reason = "the refinement reported no fit";
    return out;
  }
  for (std::size_t c = 0; c < spans.size(); ++c) {
    const auto [a, b] = spans[c];
    const bool fitted = c < r.chain_x0.size() && r.chain_x0[c].size() != 0 && r.chain_samples_used[c] >= 2;
    if (!fitted) {
      if (out.reason.empty()) out.reason = fmt::format("chain {} was not fitted", c + 1);
      continue;
    }
    for (long k = a; k < a + r.chain_samples_used[c] && k < b; ++k) out.in_fit[std::size_t(k)] = 1;
    HybridParameters p = r.estimate;
    p.x0 = r.chain_x0[c];
    p.initial_mode = c < r.chain_mode.size() ? r.chain_mode[c] : r.initial_mode;
    const Mat* covariance = r.covariance_of_chain(c, n);
    const bool gradients = covariance != nullptr;
    const SensitivityTrajectory run = RunChain(model, p, r.unknowns, t, u, spans[c], gradients);
    Store(run, a, covariance, &out.x, &out.sd);
    const Mat matched = recursive.gamma.size() == std::size_t(K)
                            ? RunMatched(model, p, r.unknowns, t, u, spans[c], recursive.gamma)
                            : Mat();
    out.matched.middleCols(a, b - a) = matched.cols() == b - a ? matched : out.x.middleCols(a, b - a);
    for (long k = 0; k < run.trajectory.size() && !out.mode.empty() && !run.trajectory.q.empty(); ++k)
      out.mode[std::size_t(a + k)] = run.trajectory.q[std::size_t(k)];
    if (run.trajectory.size() < b - a && out.reason.empty()) out.reason = Stopped(c, run, t, a);
    const double t_fit = t[std::size_t(a + r.chain_samples_used[c] - 1)];
    for (std::size_t j = 0; j < run.trajectory.jumps.size(); ++j) {
      const JumpRecord& jr = run.trajectory.jumps[j];
      FittedJump f{.time = t[std::size_t(a)] + jr.t, .se = kNaN, .chain = int(c), .map = jr.map,
                   .mode_after = jr.mode, .in_fit = t[std::size_t(a)] + jr.t <= t_fit};
      if (gradients && static_cast<Eigen::Index>(j) < run.jump_time_gradients.cols()) {
        const Vec g = run.jump_time_gradients.col(static_cast<Eigen::Index>(j));
        f.se = std::sqrt(std::max(0.0, g.dot(*covariance * g)));
      }
      out.jumps.push_back(f);
    }
  }
  return out;
}

}  // namespace hysid
