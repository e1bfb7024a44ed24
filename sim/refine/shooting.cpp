// Multiple shooting for the output-error refinement (sim/refine/shooting.hpp).
#include "sim/refine/shooting.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "sim/refine/span.hpp"

namespace hysid {
namespace {

// Ceres' relative function and parameter tolerances of the segments' fit.
constexpr double kShootingTolerance = 1e-6;

// The segments of the chains and their start.
struct Segments {
  std::vector<RefineChain> chains;  // the segments, chain by chain, in order
  FitStart start;                   // θ from the given start; each segment's ξ0 its first sample
  std::vector<std::size_t> chain;   // per segment: the chain it belongs to
  std::vector<long> first;          // per segment: its first sample in its chain
};

// The median number of samples between consecutive detected jumps (0 when fewer than two).
long MedianInterval(const std::vector<long>& at) {
  std::vector<long> d;
  for (std::size_t j = 1; j < at.size(); ++j) d.push_back(at[j] - at[j - 1]);
  if (d.empty()) return 0;
  std::nth_element(d.begin(), d.begin() + std::ssize(d) / 2, d.end());
  return d[d.size() / 2];
}

// The first samples of a chain's segments: 0, then after every `jumps` detected jumps the middle
// sample before the next one, when that interval leaves both halves at least `shortest` samples; a
// segment longer than `jumps` + 1 median intervals between detected jumps (jumps the detector
// missed) is cut into equal parts no longer than that.
std::vector<long> SegmentStarts(const std::vector<std::uint8_t>& gamma, int jumps, long shortest) {
  std::vector<long> at;
  for (std::size_t k = 1; k < gamma.size(); ++k) {
    if (gamma[k] != 0) at.push_back(static_cast<long>(k));
  }
  std::vector<long> starts{0};
  int since = 0;
  for (std::size_t j = 0; j + 1 < at.size(); ++j) {
    if (++since < jumps || at[j + 1] - at[j] < 2 * shortest) continue;
    starts.push_back((at[j] + at[j + 1]) / 2);
    since = 0;
  }
  const long cap = std::max((jumps + 1) * MedianInterval(at), 2 * shortest), end = std::ssize(gamma) - 1;
  std::vector<long> cut;
  for (std::size_t i = 0; i < starts.size(); ++i) {
    const long from = starts[i], length = (i + 1 < starts.size() ? starts[i + 1] : end) - from;
    const long parts = (length + cap - 1) / cap;
    for (long p = 0; p < parts; ++p) cut.push_back(from + p * length / parts);
  }
  return cut;
}

// Samples [begin, end] of chain `in` as a chain of their own (its first label cleared).
RefineChain Slice(const RefineChain& in, const std::vector<std::uint8_t>& gamma, long begin, long end) {
  RefineChain out;
  const long count = end - begin + 1;
  out.t.assign(in.t.begin() + begin, in.t.begin() + end + 1);
  out.y = SampleView(in.y.data() + in.y.rows() * begin, in.y.rows(), count);
  out.gamma.assign(gamma.begin() + begin, gamma.begin() + end + 1);
  out.gamma[0] = 0;
  if (in.u.rows() > 0) out.u = SampleView(in.u.data() + in.u.rows() * begin, in.u.rows(), count);
  out.owned = in.owned;  // (the samples viewed)
  out.initial_mode = in.initial_mode;
  return out;
}

// The chains of s cut into segments of `jumps` detected jumps (no jump at a boundary, no segment
// shorter than `shortest`); a segment ends at the sample the next one starts at. false when no
// chain is cut.
bool Split(const std::vector<RefineChain>& chains, const FitStart& s, int jumps, long shortest, Segments* out) {
  out->start.start = s.start;
  bool cut = false;
  for (std::size_t c = 0; c < chains.size(); ++c) {
    std::vector<long> starts = SegmentStarts(s.gamma[c], jumps, shortest);
    cut = cut || starts.size() > 1;
    starts.push_back(chains[c].y.cols() - 1);
    for (std::size_t i = 0; i + 1 < starts.size(); ++i) {
      RefineChain segment = Slice(chains[c], s.gamma[c], starts[i], starts[i + 1]);
      out->start.gamma.push_back(segment.gamma);
      out->start.x0.push_back(i == 0 ? s.x0[c] : Vec(segment.y.col(0)));
      out->start.limit.push_back(segment.y.cols());
      out->start.reason.emplace_back();
      out->start.continues.push_back(i + 2 < starts.size() ? 1 : 0);
      out->chains.push_back(std::move(segment));
      out->chain.push_back(c);
      out->first.push_back(starts[i]);
    }
  }
  return cut;
}

// After the segments' fit r: every segment fit whole has its labels placed at its own model's jumps
// (from its fitted ξ0; a label a few samples off moves there), the start moved to r's point. false
// when no label changes.
bool MendSegments(const Model& model, const RefineResult& r, const RefineOptions& options, Segments* g) {
  const long reach = 0;
  bool changed = false;
  for (std::size_t i = 0; i < g->chains.size(); ++i) {
    if (r.chain_x0[i].size() == 0 || r.chain_samples_used[i] < g->chains[i].y.cols()) continue;
    const long used = r.chain_samples_used[i];
    const std::vector<double> jumps = ModelJumps(model, g->chains[i], r.refined, r.chain_x0[i], used, options);
    std::string what;
    changed = MendFromModel(g->chains[i], "", used, jumps, reach, &g->start.gamma[i], &what) || changed;
  }
  if (!changed) return false;
  MoveTo(r, g->start);
  return true;
}

// The single-shooting start of the chains after the segments' fit r (see ShootSegments).
FitStart Join(const Segments& g, const RefineResult& r, const FitStart& s) {
  FitStart joined = s;
  joined.start.alpha = r.refined.alpha;
  joined.start.beta = r.refined.beta;
  joined.start.gamma = r.refined.gamma;
  for (std::size_t i = 0; i < g.chains.size(); ++i) {
    const std::size_t c = g.chain[i];
    const bool first = i == 0 || g.chain[i - 1] != c;
    if (first && r.chain_x0[i].size() != 0) joined.x0[c] = r.chain_x0[i];
    if (first) joined.limit[c] = static_cast<long>(s.gamma[c].size());
    if (first) joined.reason[c].clear();
    const std::vector<std::uint8_t>& labels = g.start.gamma[i];
    for (std::size_t k = 1; k < labels.size(); ++k) joined.gamma[c][static_cast<std::size_t>(g.first[i]) + k] = labels[k];
  }
  return joined;
}

}  // namespace

bool ShootSegments(const Model& model, const std::vector<RefineChain>& chains, const FitStart& s,
                   const RefineOptions& options, RefineResult* shot, FitStart* joined) {
  Segments g;
  if (!Split(chains, s, options.shooting_jumps, 2L * model.state_size() + 2, &g)) {
    *shot = RefineResult{};
    Fail(*shot, RefineStatus::kTooFewSamples, "no chain has the jumps to cut into segments");
    return false;
  }
  // Segments cut at detected jumps: a detector that flags noise cuts thousands, whose joint
  // information (dense, segments · n wide) costs minutes and gigabytes; multiple shooting by time
  // places its own nodes instead.
  if (g.chains.size() > kMaxShootingSegments) {
    *shot = RefineResult{};
    Fail(*shot, RefineStatus::kNotConverged,
         fmt::format("{} segments between detected jumps, more than {}", g.chains.size(), kMaxShootingSegments));
    return false;
  }
  // The segments' fit is only a start: a looser stop than the result's.
  RefineOptions loose = options;
  loose.function_tolerance = std::max(options.function_tolerance, kShootingTolerance);
  loose.parameter_tolerance = std::max(options.parameter_tolerance, kShootingTolerance);
  ChainFailure ignored;
  *shot = FitChains(model, g.chains, g.start, loose, &ignored);
  for (int round = 1; round < kShootingRounds && !options.stopped() && shot->chain_x0.front().size() != 0 &&
                      MendSegments(model, *shot, options, &g);
       ++round) {
    *shot = FitChains(model, g.chains, g.start, loose, &ignored);
  }
  if (shot->chain_x0.empty() || shot->chain_x0.front().size() == 0) return false;
  *joined = Join(g, *shot, s);
  shot->mended = fmt::format("multiple shooting over {} segments", g.chains.size());
  return true;
}

}  // namespace hysid
