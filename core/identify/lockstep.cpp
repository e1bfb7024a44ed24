#include "core/identify/lockstep.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <utility>

#include "core/identify/lockstep_units.hpp"

namespace hysid {
namespace {

// Below this many samples left in a block, a lockstep run is not started (as RowBlock's flow runs):
// loading and storing the units' state would cost more than it saves.
constexpr Eigen::Index kMinLockstepRun = 16;

// One block of the pass: its samples xs (2 × count, the sample before xs[0] fed already), flow rows
// (phi, y), each identifier's decisions of the block and of the chunk it lies in (`offset` samples in).
struct Block {
  const double* xs;
  Eigen::Index count;
  const double* phi;
  const double* y;
  Decision* const* decisions;
  Decision* const* chunk;
  Eigen::Index offset;
};

// Units that differ only in the detector's threshold share one identifier (the leader, the smallest
// threshold, detail::Leads) until their decisions differ: a follower is not fed, and decides flow
// wherever its leader does. At each jump of a leader with followers (detail::StopAtJumps), the
// followers that decide flow there leave: the smallest of them takes a copy of the leader's state
// (detail::AdoptState) and leads the others on. Each unit's arithmetic is its own run's, so each
// result is still bit for bit Identify's. Only without statistics (followers compute no statistic).
class Twins {
 public:
  Twins(std::vector<Identifier>& ids, bool on) : ids_(ids), leader_(ids.size(), -1) {
    for (std::size_t i = 0; on && i < ids.size(); ++i) Join(static_cast<int>(i));
    for (std::size_t i = 0; i < ids.size(); ++i)
      detail::StopAtJumps(ids_[i], HasFollowers(static_cast<int>(i)));
  }
  bool follows(std::size_t i) const { return leader_[i] >= 0; }
  int leader(std::size_t i) const { return leader_[i]; }
  bool HasFollowers(int i) const { return std::find(leader_.begin(), leader_.end(), i) != leader_.end(); }

  // Identifier i stopped at sample k of block b at a jump: the followers that decide flow there leave
  // with a copy; every part goes on to the block's end.
  void Settle(int i, Eigen::Index k, const Block& b) {
    if (k == b.count) return;  // not stopped
    std::vector<std::pair<int, Eigen::Index>> todo{{i, k}};
    while (!todo.empty()) {
      const auto [l, at] = todo.back();
      todo.pop_back();
      if (at == b.count) continue;
      const int n = Split(l, b.xs + 2 * at);
      if (n >= 0) {
        detail::AdoptState(ids_[n], ids_[l]);
        std::copy_n(b.chunk[l], b.offset + at, b.chunk[n]);  // its decisions so far: the leader's
        detail::StopAtJumps(ids_[n], HasFollowers(n));
        detail::StopAtJumps(ids_[l], HasFollowers(l));
        Decision d = detail::Stopped(ids_[l]);
        d.gamma = false;
        todo.emplace_back(n, detail::ApplyAndFeed(ids_[n], b.xs, at, b.count, b.phi, b.y, d, b.decisions[n]));
      }
      todo.emplace_back(l, detail::ApplyAndFeed(ids_[l], b.xs, at, b.count, b.phi, b.y,
                                                detail::Stopped(ids_[l]), b.decisions[l]));
    }
  }
  // The units fed at the start of a block (those that follow nobody), in order; a follower that
  // leaves within the block is fed there by Settle.
  const std::vector<int>& Fed() {
    fed_.clear();
    for (std::size_t i = 0; i < ids_.size(); ++i) {
      if (!follows(i)) fed_.push_back(static_cast<int>(i));
    }
    return fed_;
  }
  // After the pass: every follower takes its leader's state.
  void Finish() {
    for (std::size_t i = 0; i < ids_.size(); ++i) {
      if (follows(i)) detail::AdoptState(ids_[i], ids_[static_cast<std::size_t>(leader_[i])]);
    }
  }

 private:
  // Unit i follows the first leader that can lead it, or leads that leader's group when it can.
  void Join(int i) {
    for (int j = 0; j < i; ++j) {
      if (follows(static_cast<std::size_t>(j))) continue;
      if (detail::Leads(ids_[static_cast<std::size_t>(j)], ids_[static_cast<std::size_t>(i)])) {
        leader_[static_cast<std::size_t>(i)] = j;
        return;
      }
      if (detail::Leads(ids_[static_cast<std::size_t>(i)], ids_[static_cast<std::size_t>(j)])) {
        for (int& l : leader_) l = l == j ? i : l;
        leader_[static_cast<std::size_t>(j)] = i;
        return;
      }
    }
  }
  // The followers of l that do not flag sample x (where l stopped) leave l; returns the one that leads
  // them (−1: none leaves).
  int Split(int l, const double* x) {
    std::vector<int> leaving;
    for (std::size_t f = 0; f < ids_.size(); ++f) {
      if (leader_[f] == l && !detail::Flags(ids_[f], ids_[static_cast<std::size_t>(l)], x)) {
        leaving.push_back(static_cast<int>(f));
      }
    }
    if (leaving.empty()) return -1;
    int n = leaving.front();
    for (const int f : leaving) {
      if (detail::Leads(ids_[static_cast<std::size_t>(f)], ids_[static_cast<std::size_t>(n)])) n = f;
    }
    for (const int f : leaving) leader_[static_cast<std::size_t>(f)] = f == n ? -1 : n;
    return n;
  }

  std::vector<Identifier>& ids_;
  std::vector<int> leader_;  // the unit each follows; −1: fed itself
  std::vector<int> fed_;     // Fed()'s list, kept for its capacity
};

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
    const detail::PairTerms pair = detail::PairTerms::Of(p0, p1, c0, c1, inv_dt, homogeneous);
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

// The units `group` (indices into ids, each already in a flow run, its state in units[i]) over block
// b, in lockstep while they run; each ends by its own path (detail::EndFlowRun), a stop at a jump
// settled by the twins.
template <int A, bool kThreshold>
void RunTogether(std::vector<Identifier>& ids, const int* group, detail::FlowRunUnit<A>* units, int m,
                 const Block& b, double inv_dt, Twins& twins, long* taken) {
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
      out[static_cast<std::size_t>(i)] = b.decisions[group[j]];
    }
    unsigned stopped = 0;
    const Eigen::Index at = b.count - k < kMinLockstepRun ? k
                                                          : kStep[static_cast<std::size_t>(m - 1)](
                                                                unit.data(), b.xs, k, b.count, b.phi, b.y,
                                                                inv_dt, out.data(), &stopped, pending.data());
    int kept = 0;
    for (int i = 0; i < m; ++i) {
      const auto slot = static_cast<std::size_t>(i);
      const auto j = static_cast<std::size_t>(live[slot]);
      if (stopped == 0 || (stopped & (1U << i)) != 0) {  // leaves: ends by its own path
        *taken += units[j].admitted;
        const int id = group[j];
        const Eigen::Index end =
            detail::EndFlowRun(ids[static_cast<std::size_t>(id)], units[j], b.xs, at, b.count, b.phi, b.y,
                               stopped != 0 ? &pending[slot] : nullptr, b.decisions[id]);
        twins.Settle(id, end, b);
      } else {
        live[static_cast<std::size_t>(kept++)] = live[slot];
      }
    }
    m = kept;
    k = at + 1;
  }
}

// Block b fed to every identifier that is not a follower at its start.
template <int A, bool kThreshold>
void FeedBlock(std::vector<Identifier>& ids, const Block& b, double inv_dt, Twins& twins, long* taken) {
  std::array<detail::FlowRunUnit<A>, kMaxLockstep> units;
  std::array<int, kMaxLockstep> group{};
  int m = 0;
  auto run = [&] {
    RunTogether<A, kThreshold>(ids, group.data(), units.data(), m, b, inv_dt, twins, taken);
    m = 0;
  };
  for (const int i : twins.Fed()) {
    Identifier& id = ids[static_cast<std::size_t>(i)];
    const auto slot = static_cast<std::size_t>(m);
    if (b.count >= kMinLockstepRun && detail::BeginFlowRun<A>(id, &units[slot])) {
      if (m > 0 && units[slot].paper.homogeneous != units[0].paper.homogeneous) {  // another bound mode
        twins.Settle(
            i, detail::EndFlowRun(id, units[slot], b.xs, 0, b.count, b.phi, b.y, nullptr, b.decisions[i]), b);
        continue;
      }
      group[slot] = i;
      if (++m == kMaxLockstep) run();
    } else if (twins.HasFollowers(i)) {
      twins.Settle(i, detail::FeedRest(id, b.xs, 0, b.count, b.phi, b.y, b.decisions[i]), b);
    } else {
      id.Feed(ConstMatMap(b.xs, 2, b.count), b.phi, b.y, b.decisions[i]);
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
bool PassBlocks(std::vector<Identifier>& ids, const Mat& y, double dt, const FlowRows& rows,
                const std::atomic<bool>* stop, std::vector<IdentifyResult>* results, Twins& twins,
                LockstepCounts* counts) {
  const Eigen::Index count = y.cols(), chunk = IdentifyOptions::kStopPollSamples;
  std::vector<Decision> buffer(ids.size() * static_cast<std::size_t>(chunk));
  std::vector<Decision*> decisions(ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) {
    decisions[i] = buffer.data() + i * static_cast<std::size_t>(chunk);
  }
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
      const Block b{.xs = y.col(k + j).data(),
                    .count = block,
                    .phi = rows.phi.data() + 2 * (k + j),
                    .y = rows.y.data() + k + j,
                    .decisions = at_block.data(),
                    .chunk = decisions.data(),
                    .offset = j};
      FeedBlock<A, kThreshold>(ids, b, inv_dt, twins, &counts->lockstep);
    }
    for (std::size_t i = 0; i < ids.size(); ++i) {  // a follower's decisions are its leader's
      const bool follows = twins.follows(i);
      RecordDecisions(decisions[follows ? static_cast<std::size_t>(twins.leader(i)) : i], k, len,
                      &(*results)[i]);
      if (follows) counts->shared += len;
    }
  }
  return true;
}

// Without statistics (kThreshold false), units that differ only in their threshold are twins.
template <int A, bool kThreshold>
bool PassTogether(std::vector<Identifier>& ids, const Mat& y, double dt, const FlowRows& rows,
                  const std::atomic<bool>* stop, std::vector<IdentifyResult>* results,
                  LockstepCounts* counts) {
  Twins twins(ids, !kThreshold);
  const bool completed = PassBlocks<A, kThreshold>(ids, y, dt, rows, stop, results, twins, counts);
  twins.Finish();
  return completed;
}

}  // namespace

std::vector<IdentifyResult> IdentifyLockstep(const Model& model, const Mat& y, double dt,
                                             const std::vector<IdentifierSettings>& settings,
                                             const IdentifyOptions& options, LockstepCounts* counts) {
  bool together =
      settings.size() > 1 && model.state_size() == 2 && y.cols() >= 2 && y.rows() == 2 &&
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
    for (std::size_t i = 0; i < settings.size(); ++i)
      results[i] = Identify(model, y, dt, settings[i], options);
    if (counts != nullptr) counts->total += static_cast<long>(settings.size()) * y.cols();
    return results;
  }
  std::vector<Identifier> ids;
  ids.reserve(settings.size());
  for (std::size_t i = 0; i < settings.size(); ++i) {
    ids.push_back(detail::StartIdentify(model, y, dt, settings[i], options, &results[i]));
  }
  LockstepCounts taken;
  // Without statistics, no unit's threshold is reported: the runs leave it out (Decide<false>).
  using Pass = bool (*)(std::vector<Identifier>&, const Mat&, double, const FlowRows&,
                        const std::atomic<bool>*, std::vector<IdentifyResult>*, LockstepCounts*);
  const Pass pass = model.alpha_size() == 3
                        ? (options.statistics ? &PassTogether<3, true> : &PassTogether<3, false>)
                        : (options.statistics ? &PassTogether<2, true> : &PassTogether<2, false>);
  const bool completed = pass(ids, y, dt, *rows, options.stop, &results, &taken);
  if (counts != nullptr) {
    counts->lockstep += taken.lockstep;
    counts->shared += taken.shared;
    counts->total += static_cast<long>(settings.size()) * y.cols();
  }
  for (std::size_t i = 0; i < settings.size(); ++i) {
    detail::FinishIdentify(model, y, dt, settings[i], options, ids[i], completed, &results[i]);
  }
  return results;
}

}  // namespace hysid
