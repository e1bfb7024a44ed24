// The recoveries of the output-error refinement: the span cut before the first disagreement between
// the model's jumps and the detected ones, and the adoption of the fit from a repaired start.
// Internal to sim/refine.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "sim/refine/refine.hpp"

namespace hysid {

// The sample times of one span: k·dt on a grid, or times[k] when `times` is set.
struct SampleClock {
  double dt = 0.0;
  const std::vector<double>* times = nullptr;
  // How far t lies outside the detected interval (t_{k−1}, t_k], in that interval's own step (0 inside).
  double Off(double t, long k) const;
  // The last sample at or before t (floor(t/δt) on a grid).
  long SampleOf(double t) const;
};

// The first sample at which the model's jumps (in order) and the detected ones (where `segments`
// steps) disagree: the earlier of the model's jump j and detected jump j when they are more than
// `tolerance` samples apart, or the first jump either has without a counterpart. −1 when they all
// agree.
long FirstDisagreement(const std::vector<JumpRecord>& jumps, const std::vector<int>& segments,
                       const SampleClock& clock, double tolerance);

// The retries of RefineOptions::max_span_retries: a failure they may mend (the model's jumps and the
// detected ones disagree), the margin a shorter span ends before the first disagreement, and the
// reason reported for the samples left out.
bool SpanRetryable(RefineStatus status);
long SpanMargin(const RefineOptions& options);
std::string SpanRetryReason(long used, RefineStatus failed, long disagreement);
// Why the span rule (RefineOptions::min_jump_interval) left samples out.
std::string CloseJumpsReason(const RefineOptions& options);

// Chain `chain`'s labels over its first `used` samples mended from its model's own jump times
// `jumps` (from the chain's first sample): a model jump with a detection within `reach` samples keeps
// that detection (the nearest not yet taken), one without is added at the sample whose interval
// (t_{k−1}, t_k] holds it, and a detection no model jump takes is dropped. false (nothing changed)
// when a model jump lies outside the span, two fall in one interval, or none is added or dropped.
// *what: "LABEL A added, D dropped".
bool MendFromModel(const RefineChain& chain, const std::string& label, long used,
                   const std::vector<double>& jumps, long reach, std::vector<std::uint8_t>* gamma,
                   std::string* what);

// The jump times (from the chain's first sample) of the model at p, from x0, on its own over the
// chain's first `used` samples (plain mode, states only); empty when it does not complete.
std::vector<double> ModelJumps(const Model& model, const RefineChain& chain, HybridParameters p,
                               const Vec& x0, long used, const RefineOptions& options);

// Whether the samples the span rule (RefineOptions::min_jump_interval) left out of the ok fit r hold
// jumps the sample rate does not resolve: every chain it cut (and no chain cut otherwise or left out)
// has, on the model at r.refined run on its own over all its samples, two jumps after its last fitted
// sample less than two mean steps apart (at most one sample between them), or its jumps accumulating
// (Zeno) before its last sample. *at: the earlier of the first such two jumps' time, the latest over
// the chains.
bool ModelJumpsUnresolved(const Model& model, const std::vector<RefineChain>& chains, const RefineResult& r,
                          const RefineOptions& options, double* at);

// The fit from a repaired start (`repaired`, the repair described by `summary`) against the fit from
// the recursive estimate (r): it replaces r when it is ok and r is not, or fits more samples (its
// start then the recursive estimate, start_repair the summary); else r is kept, and when r is not ok
// its reason says how the second attempt ended.
void AdoptRepaired(RefineResult& r, RefineResult repaired, const std::string& summary);

}  // namespace hysid
