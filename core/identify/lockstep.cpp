#include "core/identify/lockstep.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <utility>

#include "core/identify/flow_run_unit.hpp"

namespace hysid {
namespace {

// Below this many samples left in a block, a lockstep run is not started (as RowBlock's flow runs):
// loading and storing the units' state would cost more than it saves.
constexpr Eigen::Index kMinLockstepRun = 16;

// M flow runs (all in one bound mode) from sample k of a block (xs, phi, y: its samples and rows;
// sample k − 1 is xs[2k − 2 …], before the block's start too) stepped side by side until one stops.
// Returns the sample they stopped at (count: the block is done). *stopped: a bit per unit whose run
// stopped there, its decision in pending[i]; the others took that sample. 0 with a result below
// count: the sample's row is not finite and no unit took it. kThreshold false: the decisions
// without their thresholds (nobody reads them), L̂ settled once at the end.
template <int A, bool kThreshold, int M>
Eigen::Index StepTogether(detail::FlowRunUnit<A>* const* units, const double* xs, Eigen::Index k,
                          Eigen::Index count, const double* phi, const double* y, double inv_dt,
                          Decision* const* decisions, unsigned* stopped, Decision* pending) {
  std::array<detail::FlowRunUnit<A>, M> u;
  for (int i = 0; i < M; ++i) u[i] = *units[i];
  const bool homogeneous = u[0].paper.homogeneous;  // every unit's (FeedBlock)
  unsigned stop = 0;
  bool seen = false;  // a sample classified: its ξ(t) and ‖ξ(t)‖ are the detectors' last
  double p0 = xs[2 * k - 2], p1 = xs[2 * k - 1], norm = 0.0;
  for (; k < count; ++k) {
    const double f0 = phi[2 * k], f1 = phi[2 * k + 1], yk = y[k];
    if (!(std::isfinite(f0) && std::isfinite(f1) && std::isfinite(yk))) break;
    const double c0 = xs[2 * k], c1 = xs[2 * k + 1];
    const detail::PairTerms2 pair = detail::PairTerms2::Of(p0, p1, c0, c1, inv_dt, homogeneous);
    seen = true;
    norm = pair.cur_norm;
#pragma GCC unroll 8
    for (int i = 0; i < M; ++i) {
      Decision d;
      if (u[i].template Step<kThreshold>(pair, f0, f1, yk, &d)) {
        decisions[i][k] = d;
      } else {
        pending[i] = d;
        stop |= 1U << i;
      }
    }
    p0 = c0;
    p1 = c1;
    if (stop != 0) break;
  }
  for (int i = 0; i < M; ++i) {
    if (seen) u[i].paper.Saw(p0, p1, norm);
    if constexpr (!kThreshold) u[i].paper.Settle();
    *units[i] = u[i];
  }
  *stopped = stop;
  return k;
}

template <int A>
using StepFn = Eigen::Index (*)(detail::FlowRunUnit<A>* const*, const double*, Eigen::Index, Eigen::Index,
                                const double*, const double*, double, Decision* const*, unsigned*, Decision*);

template <int A, bool kThreshold, std::size_t... M>
constexpr std::array<StepFn<A>, sizeof...(M)> StepTable(std::index_sequence<M...>) {
  return {&StepTogether<A, kThreshold, static_cast<int>(M) + 1>...};
}

// The units `ids` (each already in a flow run, its state in units[i]) over one block, in lockstep
// while they run; each ends by its own path (Identifier::EndFlowRun).
template <int A, bool kThreshold>
void RunTogether(Identifier* const* ids, detail::FlowRunUnit<A>* units, int m, const double* xs,
                 Eigen::Index count, const double* phi, const double* y, double inv_dt, Decision* const* decisions,
                 long* taken) {
  static constexpr auto kStep = StepTable<A, kThreshold>(std::make_index_sequence<kMaxLockstep>{});
  std::array<int, kMaxLockstep> live{};  // the units still in the lockstep
  std::array<detail::FlowRunUnit<A>*, kMaxLockstep> unit{};
  std::array<Decision*, kMaxLockstep> out{};
  std::array<Decision, kMaxLockstep> pending{};
  for (int i = 0; i < m; ++i) live[static_cast<std::size_t>(i)] = i;
  Eigen::Index k = 0;
  while (m > 0) {
    for (int i = 0; i < m; ++i) {
      const auto j = static_cast<std::size_t>(live[static_cast<std::size_t>(i)]);
      unit[static_cast<std::size_t>(i)] = &units[j];
      out[static_cast<std::size_t>(i)] = decisions[j];
    }
    unsigned stopped = 0;
    const Eigen::Index at =
        count - k < kMinLockstepRun
            ? k
            : kStep[static_cast<std::size_t>(m - 1)](unit.data(), xs, k, count, phi, y, inv_dt, out.data(),
                                                      &stopped, pending.data());
    int kept = 0;
    for (int i = 0; i < m; ++i) {
      const auto slot = static_cast<std::size_t>(i);
      const auto j = static_cast<std::size_t>(live[slot]);
      if (stopped == 0 || (stopped & (1U << i)) != 0) {  // leaves: ends by its own path
        *taken += units[j].admitted;
        ids[j]->EndFlowRun(units[j], xs, at, count, phi, y, stopped != 0 ? &pending[slot] : nullptr, decisions[j]);
      } else {
        live[static_cast<std::size_t>(kept++)] = live[slot];
      }
    }
    m = kept;
    k = at + 1;
  }
}

// One block (xs: n × count from the second sample on; phi, y its rows) fed to every identifier.
template <int A, bool kThreshold>
void FeedBlock(std::vector<Identifier>& ids, const double* xs, Eigen::Index count, const double* phi,
               const double* y, double inv_dt, Decision* const* decisions, long* taken) {
  std::array<detail::FlowRunUnit<A>, kMaxLockstep> units;
  std::array<Identifier*, kMaxLockstep> group{};
  std::array<Decision*, kMaxLockstep> out{};
  int m = 0;
  auto run = [&] {
    RunTogether<A, kThreshold>(group.data(), units.data(), m, xs, count, phi, y, inv_dt, out.data(), taken);
    m = 0;
  };
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const auto slot = static_cast<std::size_t>(m);
    if (count >= kMinLockstepRun && ids[i].BeginFlowRun<A>(&units[slot])) {
      if (m > 0 && units[slot].paper.homogeneous != units[0].paper.homogeneous) {  // another bound mode
        ids[i].EndFlowRun(units[slot], xs, 0, count, phi, y, nullptr, decisions[i]);
        continue;
      }
      group[slot] = &ids[i];
      out[slot] = decisions[i];
      if (++m == kMaxLockstep) run();
    } else {
      ids[i].Feed(ConstMatMap(xs, 2, count), phi, y, decisions[i]);
    }
  }
  if (m > 0) run();
}

// The decisions of samples k … k + len − 1 into r.
void RecordDecisions(const Decision* d, Eigen::Index k, Eigen::Index len, IdentifyResult* r) {
  for (Eigen::Index j = 0; j < len; ++j) {
    const auto at = static_cast<std::size_t>(k + j);
    r->gamma[at] = d[j].gamma ? 1 : 0;
    if (r->statistic.empty()) continue;  // IdentifyOptions::statistics off
    r->statistic[at] = d[j].statistic;
    r->threshold[at] = d[j].threshold;
  }
}

// The pass of every identifier, in lockstep where they take flow runs; false when stopped.
template <int A, bool kThreshold>
bool PassTogether(std::vector<Identifier>& ids, const Mat& y, double dt, const FlowRows& rows,
                  const std::atomic<bool>* stop, std::vector<IdentifyResult>* results, long* taken) {
  const Eigen::Index count = y.cols(), chunk = IdentifyOptions::kStopPollSamples;
  std::vector<Decision> buffer(ids.size() * static_cast<std::size_t>(chunk));
  std::vector<Decision*> decisions(ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) decisions[i] = buffer.data() + i * static_cast<std::size_t>(chunk);
  std::vector<Decision*> at_block(ids.size());  // the decisions of a block's first sample
  const double inv_dt = 1.0 / dt;
  for (Eigen::Index k = 0; k < count; k += chunk) {
    if (stop != nullptr && stop->load(std::memory_order_relaxed)) return false;
    const Eigen::Index len = std::min(chunk, count - k);
    Eigen::Index j = 0;
    if (k == 0) {  // the first sample only initialises
      for (std::size_t i = 0; i < ids.size(); ++i) ids[i].Feed(y.leftCols(1), nullptr, nullptr, decisions[i]);
      j = 1;
    }
    for (; j < len; j += kLockstepBlock) {
      const Eigen::Index block = std::min(kLockstepBlock, len - j);
      for (std::size_t i = 0; i < ids.size(); ++i) at_block[i] = decisions[i] + j;
      FeedBlock<A, kThreshold>(ids, y.col(k + j).data(), block, rows.phi.data() + 2 * (k + j), rows.y.data() + k + j, inv_dt,
                   at_block.data(), taken);
    }
    for (std::size_t i = 0; i < ids.size(); ++i) RecordDecisions(decisions[i], k, len, &(*results)[i]);
  }
  return true;
}

}  // namespace

std::vector<IdentifyResult> IdentifyLockstep(const Model& model, const Mat& y, double dt,
                                             const std::vector<IdentifierSettings>& settings,
                                             const IdentifyOptions& options, LockstepCounts* counts) {
  bool together = settings.size() > 1 && model.state_size() == 2 && y.cols() >= 2 && y.rows() == 2 &&
                  std::none_of(settings.begin(), settings.end(), [](const auto& s) { return s.second_pass; }) &&
                  detail::PassInBlocks(model, y, options);
  FlowRows own;
  const FlowRows* rows = options.flow_rows;
  if (together && (rows == nullptr || rows->empty())) {
    own = BuildFlowRows(model, y, dt);
    rows = &own;
  }
  together = together && !rows->empty() && rows->phi.size() == 2 * rows->y.size();  // one row, two unknowns
  std::vector<IdentifyResult> results(settings.size());
  if (!together) {
    for (std::size_t i = 0; i < settings.size(); ++i) results[i] = Identify(model, y, dt, settings[i], options);
    if (counts != nullptr) counts->total += static_cast<long>(settings.size()) * y.cols();
    return results;
  }
  std::vector<Identifier> ids;
  ids.reserve(settings.size());
  for (std::size_t i = 0; i < settings.size(); ++i) {
    ids.push_back(detail::StartIdentify(model, y, dt, settings[i], options, &results[i]));
  }
  long taken = 0;
  // Without statistics, no unit's threshold is reported: the runs leave it out (Decide<false>).
  const auto pass = model.alpha_size() == 3 ? (options.statistics ? &PassTogether<3, true> : &PassTogether<3, false>)
                                            : (options.statistics ? &PassTogether<2, true> : &PassTogether<2, false>);
  const bool completed = pass(ids, y, dt, *rows, options.stop, &results, &taken);
  if (counts != nullptr) {
    counts->lockstep += taken;
    counts->total += static_cast<long>(settings.size()) * y.cols();
  }
  for (std::size_t i = 0; i < settings.size(); ++i) {
    detail::FinishIdentify(model, y, dt, settings[i], options, ids[i], completed, &results[i]);
  }
  return results;
}

}  // namespace hysid
