// Detections mended from the fitted model (sim/refine/mend.hpp).
#include "sim/refine/mend.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include <fmt/format.h>

#include "sim/refine/span.hpp"

namespace hysid {

namespace {

// Labels added and dropped over all chains: `after` against `before`.
std::pair<int, int> LabelChanges(const std::vector<RefineChain>& chains,
                                 const std::vector<std::vector<std::uint8_t>>& after) {
  int added = 0, dropped = 0;
  for (std::size_t c = 0; c < chains.size(); ++c) {
    for (std::size_t k = 1; k < chains[c].gamma.size(); ++k) {
      added += after[c][k] != 0 && chains[c].gamma[k] == 0 ? 1 : 0;
      dropped += after[c][k] == 0 && chains[c].gamma[k] != 0 ? 1 : 0;
    }
  }
  return {added, dropped};
}

std::string Joined(const std::string& before, const std::string& what) {
  return before.empty() ? what : before + "; " + what;
}

// Whether fit b (from the same data) is better than the ok fit a: ok and more samples, or as many at
// a lower cost.
bool Betters(const RefineResult& b, const RefineResult& a) {
  return b.ok() && (b.samples_used > a.samples_used ||
                    (b.samples_used == a.samples_used && b.final_cost < a.final_cost));
}

// The model jumps (times from the chain's first sample) with no label within `reach` samples of the
// sample whose interval holds them, labelled there. The number added.
int AddUnlabelled(const RefineChain& chain, const std::vector<double>& jumps, long reach,
                  std::vector<std::uint8_t>* gamma) {
  const auto k_count = static_cast<long>(chain.t.size());
  int added = 0;
  for (const double tau : jumps) {
    const long k = std::lower_bound(chain.t.begin(), chain.t.end(), chain.t.front() + tau) - chain.t.begin();
    if (k < 1 || k >= k_count) continue;
    bool near = false;
    for (long d = std::max(1L, k - reach); d <= std::min(k_count - 1, k + reach) && !near; ++d) {
      near = (*gamma)[static_cast<std::size_t>(d)] != 0;
    }
    if (near) continue;
    (*gamma)[static_cast<std::size_t>(k)] = 1;
    ++added;
  }
  return added;
}

// s's labels of every fitted chain of r over all its samples mended from r's model's own jumps
// (spans whole again): placed at them (`place`: MendFromModel with reach 0), else only those with no
// label within `reach` samples added. false when no label changes.
bool LabelModelJumps(const Model& model, const std::vector<RefineChain>& chains, const RefineOptions& options,
                     const RefineResult& r, bool place, long reach, FitStart* s) {
  bool changed = false;
  for (std::size_t c = 0; c < chains.size(); ++c) {
    const long k_count = chains[c].y.cols();
    if (r.chain_x0[c].size() == 0 || k_count < 2) continue;
    const std::vector<double> jumps = ModelJumps(model, chains[c], r.refined, r.chain_x0[c], k_count, options);
    if (jumps.empty()) continue;
    std::string what;
    const bool moved = place ? MendFromModel(chains[c], "", k_count, jumps, 0, &s->gamma[c], &what)
                             : AddUnlabelled(chains[c], jumps, reach, &s->gamma[c]) > 0;
    if (!moved) continue;
    s->limit[c] = k_count;
    s->reason[c].clear();
    changed = true;
  }
  if (changed) MoveTo(r, *s);
  return changed;
}

}  // namespace

bool MendFromFit(const Model& model, const std::vector<RefineChain>& chains, const RefineOptions& options,
                 ChainFailure failure, long reach, FitStart& s, RefineResult& r) {
  FitStart m = s;
  RefineResult at = r;
  for (int round = 0; round < kMendRounds && !options.stopped(); ++round) {
    if (failure.chain < 0 || failure.model_jumps.empty()) return false;
    const auto c = static_cast<std::size_t>(failure.chain);
    MoveTo(at, m);
    m.gamma[c] = s.gamma[c];  // each round mends the labels it started from: a kept label stays put
    std::string what;
    if (!MendFromModel(chains[c], "", at.chain_samples_used[c], failure.model_jumps, reach, &m.gamma[c], &what)) {
      return false;
    }
    RefineResult next = FitChains(model, chains, m, options, &failure);
    if (next.ok()) {
      if (next.samples_used < r.samples_used) return false;  // (added jumps may shorten a span)
      const auto [added, dropped] = LabelChanges(chains, m.gamma);
      const std::string label = chains.size() > 1 ? fmt::format("chain {}: ", c + 1) : "";
      next.start = r.start;
      next.mended = Joined(r.mended, fmt::format("{}{} added, {} dropped", label, added, dropped));
      r = std::move(next);
      s = std::move(m);
      return true;
    }
    if (!SpanRetryable(next.status)) return false;
    at = std::move(next);
  }
  return false;
}

bool SettleAtModelJumps(const Model& model, const std::vector<RefineChain>& chains,
                        const RefineOptions& options, bool place, FitStart& s, RefineResult& r) {
  if (!r.ok()) return false;
  const std::string before = r.mended;
  bool better = false;
  for (int round = 0; round < kMendRounds && !options.stopped(); ++round) {
    FitStart m = s;
    // (Adding: a model jump nearer a label than min_jump_interval is that label's, or unresolvable.)
    const long reach = std::max(static_cast<long>(std::ceil(options.jump_time_tolerance)) + 1,
                                place ? 0L : options.min_jump_interval);
    if (!LabelModelJumps(model, chains, options, r, place, reach, &m)) break;
    ChainFailure failure;
    RefineResult next = FitChains(model, chains, m, options, &failure);
    // Jumps that moved off their labels as the fit moved: the labels follow them.
    if (place && !next.ok() && SpanRetryable(next.status)) MendFromFit(model, chains, options, failure, 0, m, next);
    if (!Betters(next, r)) break;
    next.start = r.start;
    next.start_repair = r.start_repair;
    r = std::move(next);
    s = std::move(m);
    better = true;
  }
  if (!better) return false;
  const auto [added, dropped] = LabelChanges(chains, s.gamma);
  r.mended = Joined(before, fmt::format("{}: {} added, {} dropped",
                                        place ? "labels at the model's jumps" : "the model's unlabelled jumps added",
                                        added, dropped));
  return true;
}

}  // namespace hysid
