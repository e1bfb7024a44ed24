#include "sim/refine/span.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include <fmt/format.h>

#include "sim/refine/fit.hpp"

namespace hysid {

double SampleClock::Off(double t, long k) const {
  if (times == nullptr) {
    const double lo = static_cast<double>(k - 1) * dt, hi = static_cast<double>(k) * dt;
    return t < lo ? (lo - t) / dt : (t > hi ? (t - hi) / dt : 0.0);
  }
  const double lo = (*times)[static_cast<std::size_t>(k - 1)], hi = (*times)[static_cast<std::size_t>(k)];
  return (t < lo ? lo - t : (t > hi ? t - hi : 0.0)) / (hi - lo);
}

long SampleClock::SampleOf(double t) const {
  if (times == nullptr) return static_cast<long>(std::floor(t / dt));
  const auto after = std::upper_bound(times->begin(), times->end(), t);
  return static_cast<long>(after - times->begin()) - 1;
}

long FirstDisagreement(const std::vector<JumpRecord>& jumps, const std::vector<int>& segments,
                       const SampleClock& clock, double tolerance) {
  std::vector<long> detected;  // first sample of each later segment
  for (std::size_t k = 1; k < segments.size(); ++k) {
    if (segments[k] != segments[k - 1]) detected.push_back(static_cast<long>(k));
  }
  const std::size_t common = std::min(jumps.size(), detected.size());
  for (std::size_t j = 0; j < common; ++j) {
    if (clock.Off(jumps[j].t, detected[j]) > tolerance) {
      return std::min(detected[j] - 1, clock.SampleOf(jumps[j].t));
    }
  }
  if (jumps.size() > common) return clock.SampleOf(jumps[common].t);
  if (detected.size() > common) return detected[common] - 1;
  return -1;
}

bool SpanRetryable(RefineStatus status) {
  return status == RefineStatus::kJumpCountMismatch || status == RefineStatus::kStartFailed;
}

long SpanMargin(const RefineOptions& options) {
  return static_cast<long>(std::ceil(options.jump_time_tolerance)) + 2;
}

std::string SpanRetryReason(long used, RefineStatus failed, long disagreement) {
  return fmt::format(
      "the fit of the first {} samples ended in {}: the model's jumps and the "
      "detected ones disagree from sample {}",
      used, ToString(failed), disagreement);
}

std::string CloseJumpsReason(const RefineOptions& options) {
  return fmt::format("later detected jumps are closer than {} samples", options.min_jump_interval);
}

void AdoptRepaired(RefineResult& r, RefineResult repaired, const std::string& summary) {
  if (repaired.ok() && (!r.ok() || repaired.samples_used > r.samples_used)) {
    repaired.start = r.start;  // the recursive estimate, kept when the result is not ok
    repaired.start_repair = summary;
    r = std::move(repaired);
    return;
  }
  if (r.ok()) return;
  r.reason += fmt::format("; from a repaired start ({}): {}: {}", summary, ToString(repaired.status),
                          repaired.reason);
}

// Chain c's labels over its first `used` samples mended from its fitted model's own jump times
// (from the chain's first sample): a model jump with a detection within `reach` samples keeps that
// detection (the nearest not yet taken), one without is added at the sample whose interval
// (t_{k−1}, t_k] holds it, and a detection no model jump takes is dropped. false when a model jump
// lies outside the span or two fall in one interval. *what: "LABEL A added, D dropped".
bool MendFromModel(const RefineChain& chain, const std::string& label, long used,
                   const std::vector<double>& jumps, long reach, std::vector<std::uint8_t>* gamma,
                   std::string* what) {
  std::vector<std::uint8_t> mended(gamma->size(), 0), taken(gamma->size(), 0);
  std::copy(gamma->begin() + used, gamma->end(), mended.begin() + used);
  const auto end = chain.t.begin() + used;
  int added = 0;
  for (double tau : jumps) {
    const long k = std::lower_bound(chain.t.begin(), end, chain.t.front() + tau) - chain.t.begin();
    if (k < 1 || k >= used) return false;
    long best = -1;
    for (long d = std::max(1L, k - reach); d <= std::min(used - 1, k + reach); ++d) {
      const auto u = static_cast<std::size_t>(d);
      if ((*gamma)[u] != 0 && !taken[u] && (best < 0 || std::abs(d - k) < std::abs(best - k))) best = d;
    }
    const auto at = static_cast<std::size_t>(best >= 0 ? best : k);
    if (mended[at] != 0) return false;
    mended[at] = taken[at] = 1;
    added += best < 0 ? 1 : 0;
  }
  int dropped = 0;
  for (long k = 1; k < used; ++k) {
    const auto u = static_cast<std::size_t>(k);
    dropped += (*gamma)[u] != 0 && !taken[u] ? 1 : 0;
  }
  if (added + dropped == 0) return false;
  *gamma = std::move(mended);
  *what = fmt::format("{}{} added, {} dropped", label, added, dropped);
  return true;
}

namespace {

// The model at p, from x0, on its own over the chain's first `used` samples (plain mode, states only;
// times from the chain's first sample).
SensitivityTrajectory OnItsOwn(const Model& model, const RefineChain& chain, HybridParameters p,
                               const Vec& x0, long used, const RefineOptions& options) {
  SensitivityOptions o = options.sensitivity;
  o.sensitivities = false;
  p.x0 = x0;
  const double t_end = chain.t[static_cast<std::size_t>(used - 1)] - chain.t.front();
  const InputSignal inputs = ChainInputs(chain, used);
  return SimulateSensitivities(model, p, Unknowns::Of(model), EvenGrid(t_end, used), o, InputsOf(inputs));
}

}  // namespace

// The jump times (from the chain's first sample) of the model at p, from x0, on its own over the
// chain's first `used` samples (plain mode, states only); empty when it does not complete.
std::vector<double> ModelJumps(const Model& model, const RefineChain& chain, HybridParameters p,
                               const Vec& x0, long used, const RefineOptions& options) {
  const SensitivityTrajectory plain = OnItsOwn(model, chain, std::move(p), x0, used, options);
  std::vector<double> jumps;
  if (!plain.trajectory.status.completed()) return jumps;
  for (const JumpRecord& jump : plain.trajectory.jumps) jumps.push_back(jump.t);
  return jumps;
}

bool ModelJumpsUnresolved(const Model& model, const std::vector<RefineChain>& chains, const RefineResult& r,
                          const RefineOptions& options, double* at) {
  if (!r.ok() || r.chain_samples_used.size() != chains.size() || r.chain_x0.size() != chains.size())
    return false;
  bool cut = false;
  *at = 0.0;
  for (std::size_t c = 0; c < chains.size(); ++c) {
    const RefineChain& chain = chains[c];
    const long used = r.chain_samples_used[c], k_count = chain.y.cols();
    if (used == k_count) continue;
    if (used == 0 || r.chain_span_reason[c] != CloseJumpsReason(options) || r.chain_x0[c].size() == 0)
      return false;
    cut = true;
    HybridParameters p = r.refined;
    if (chain.initial_mode >= 0) p.initial_mode = chain.initial_mode;
    const double t_fitted = chain.t[static_cast<std::size_t>(used - 1)] - chain.t.front();
    const double two_steps = 2.0 * (chain.t.back() - chain.t.front()) / static_cast<double>(k_count - 1);
    const SensitivityTrajectory plain = OnItsOwn(model, chain, std::move(p), r.chain_x0[c], k_count, options);
    const SimStatus& status = plain.trajectory.status;
    const std::vector<JumpRecord>& jumps = plain.trajectory.jumps;
    double first = -1.0;
    for (std::size_t j = 1; j < jumps.size() && first < 0.0; ++j) {
      if (jumps[j].t > t_fitted && jumps[j].t - jumps[j - 1].t < two_steps) first = jumps[j - 1].t;
    }
    if (first < 0.0 && status.stop == SimStop::kZeno && status.zeno_time > t_fitted) first = status.zeno_time;
    if (first < 0.0 || (!status.completed() && status.stop != SimStop::kZeno)) return false;
    *at = std::max(*at, chain.t.front() + first);
  }
  return cut;
}

}  // namespace hysid
