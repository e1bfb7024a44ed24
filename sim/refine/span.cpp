#include "sim/refine/span.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

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

}  // namespace hysid
