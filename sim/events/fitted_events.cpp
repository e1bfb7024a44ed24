#include "sim/events/fitted_events.hpp"

#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "sim/input_signal.hpp"

namespace hysid {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The first sample (data index) of every chain, as SplitChains and AssignChainMaps cut them.
std::vector<long> ChainFirsts(const std::vector<std::uint8_t>& chain_start, long samples) {
  std::vector<long> first;
  for (long k = 0; k < samples; ++k) {
    if (k == 0 || (!chain_start.empty() && chain_start[std::size_t(k)] != 0)) first.push_back(k);
  }
  return first;
}

// The chain's inputs over its first `used` samples, on its own clock (empty without inputs).
InputSignal UsedInputs(const RefineChain& chain, long used) {
  InputSignal s;
  if (chain.u.rows() == 0) return s;
  for (long k = 0; k < used; ++k) s.times.push_back(chain.t[std::size_t(k)] - chain.t.front());
  s.values = chain.u.leftCols(used);
  return s;
}

// The fitted model on chain c over its first `used` samples from its fitted x0 and mode, with ∂t_j/∂θ when
// `gradients`.
SensitivityTrajectory RunChain(const Model& model, const RefineResult& r, std::size_t c, const RefineChain& chain,
                               long used, bool gradients, SensitivityOptions options) {
  HybridParameters p = r.estimate;
  p.x0 = r.chain_x0[c];
  p.initial_mode = c < r.chain_mode.size() ? r.chain_mode[c] : chain.initial_mode >= 0 ? chain.initial_mode : r.initial_mode;
  options.sensitivities = gradients;
  const double t_end = chain.t[std::size_t(used - 1)] - chain.t.front();
  const SampleGrid grid = EvenGrid(t_end, used);
  const InputSignal inputs = UsedInputs(chain, used);
  return SimulateSensitivities(model, p, r.unknowns, grid, options, inputs.empty() ? nullptr : &inputs);
}

}  // namespace

FittedEvents FitEventTimes(const Model& model, const std::vector<double>& t, const Mat& y,
                           const std::vector<std::uint8_t>& chain_start, const Mat& u,
                           const IdentifyResult& recursive, const RefineResult& r,
                           const SensitivityOptions& options) {
  FittedEvents out;
  out.time.assign(recursive.events.size(), kNaN);
  out.se.assign(recursive.events.size(), kNaN);
  if (!r.ok()) {
    out.reason = fmt::format("the refinement is not ok ({})", ToString(r.status));
    return out;
  }
  std::vector<RefineChain> chains = SplitChains(t, y, chain_start, recursive.gamma, u);
  AssignChainMaps(chain_start, recursive, &chains);
  const std::vector<long> first = ChainFirsts(chain_start, y.cols());
  for (std::size_t c = 0; c < chains.size() && c < first.size(); ++c) {
    const bool fitted = c < r.chain_x0.size() && r.chain_x0[c].size() != 0 && r.chain_samples_used[c] >= 2;
    if (!fitted) {
      out.reason = fmt::format("chain {} was not fitted", c + 1);
      continue;
    }
    const RefineChain& chain = chains[c];
    const auto used = static_cast<long>(chain.t.size());  // the whole chain, past a span the fit cut
    if (r.chain_samples_used[c] < used && out.beyond.empty()) {
      out.beyond = fmt::format("chain {}: after t = {:.6g} the fit left out the samples (the fitted model's prediction)",
                               c + 1, chain.t[std::size_t(r.chain_samples_used[c] - 1)]);
    }
    const Mat* covariance = r.covariance_of_chain(c, model.state_size());
    const bool gradients = covariance != nullptr;
    const SensitivityTrajectory run = RunChain(model, r, c, chain, used, gradients, options);
    if (!run.trajectory.status.completed()) {
      out.reason = fmt::format("chain {}: the fitted model does not run ({})", c + 1, run.trajectory.status.message);
      continue;
    }
    const std::vector<JumpRecord>& jumps = run.trajectory.jumps;
    for (const JumpRecord& j : jumps) {
      out.crossings.push_back({.time = chain.t.front() + j.t, .map = j.map, .chain = static_cast<int>(c)});
    }
    // Each detected event of the chain against the crossing nearest its time: paired when that
    // crossing applies the event's map and no other event of the chain is nearer to it (a crossing
    // the detector missed pairs with no event; a detection with no crossing of its map there, none).
    const long begin = first[c], end = c + 1 < first.size() ? first[c + 1] : y.cols();
    constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
    std::vector<std::size_t> paired(jumps.size(), kNone);  // per crossing: the event it is paired with
    auto distance = [&](std::size_t j, std::size_t i) {
      return std::abs(chain.t.front() + jumps[j].t - recursive.events[i].time);
    };
    for (std::size_t i = 0; i < recursive.events.size() && !jumps.empty(); ++i) {
      const AutomatonEvent& e = recursive.events[i];
      if (e.sample <= begin || e.sample >= end) continue;
      std::size_t j = 0;
      for (std::size_t k = 1; k < jumps.size(); ++k) j = distance(k, i) < distance(j, i) ? k : j;
      if (jumps[j].map != e.map) {
        if (out.reason.empty()) {
          out.reason = fmt::format(
              "chain {}: the fitted model's crossing nearest the event at sample {} (t = {:.6g}) "
              "applies another map",
              c + 1, e.sample, chain.t.front() + jumps[j].t);
        }
        continue;
      }
      if (paired[j] == kNone || distance(j, i) < distance(j, paired[j])) paired[j] = i;
    }
    for (std::size_t j = 0; j < jumps.size(); ++j) {
      if (paired[j] == kNone) continue;
      out.time[paired[j]] = chain.t.front() + jumps[j].t;
      if (gradients && static_cast<Eigen::Index>(j) < run.jump_time_gradients.cols()) {
        const Vec g = run.jump_time_gradients.col(static_cast<Eigen::Index>(j));
        out.se[paired[j]] = std::sqrt(std::max(0.0, g.dot(*covariance * g)));
      }
    }
  }
  if (out.reason.empty()) {
    for (std::size_t i = 0; i < out.time.size(); ++i) {
      if (std::isnan(out.time[i])) {
        out.reason = fmt::format(
            "the event at sample {} has no crossing of its own: another event of its chain "
            "is nearer to the crossing nearest it",
            recursive.events[i].sample);
        break;
      }
    }
  }
  return out;
}

}  // namespace hysid
