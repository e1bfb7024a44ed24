// The unmeasured states of a partly measured run, reconstructed as a start for identification (never
// as data: the refinement fits the measured outputs only, sim/refine/refine.hpp).
//
// Which states: an unmeasured state i is reconstructed from a measured state j whose flow is
// f_j(ξ) = c ξ_i + d with c ≠ 0 and d known constants (ξ_j' = c ξ_i + d: a position measured, its
// velocity not): ξ̂_i = (dξ̂_j/dt − d)/c. Found from the model's flow Jacobian at a few states (row j
// constant, one nonzero entry, in column i; row j not an identified row). A state with no such
// measured partner cannot be reconstructed (ReconstructionPlan::error names it).
//
// Jumps: the jump of an unmeasured velocity is a kink in the measured position. Per interval
// (t_k, t_{k+1}] the slope change Δs_k = s⁺ − s⁻ between the chords of `chord` (w) samples on either
// side, s⁻ over [t_{k−w}, t_k] and s⁺ over [t_{k+1}, t_{k+1+w}] (both clear of the interval), less
// its running median (the flow's own curvature), over its noise sd σ√(2/T⁻² + 2/T⁺²) (T± the
// chords' durations) is the statistic; a jump is labelled at sample k+1 where the statistic exceeds
// the threshold and is the largest within ±w samples (the neighbouring intervals' chords share the
// kink) and at least w/2 samples in from either end of the statistic (its rise and fall in sight).
// Longer chords see smaller kinks (the sd falls as 1/w) but need w samples of flow on either side:
// the longest chord is the shortest one (`chord`, 4) or, when longer, the one whose statistic's sd
// 2σ/(wδt) is `kink_precision` (20 %) of the measured row's slope scale (its range over the chain's
// duration), at most a tenth of the chain (fast sampling: 4 samples at 8 kHz would leave a 10 m/s
// bounce at 1 mm noise below 3 sd). Kinks closer together than that chord (a body between two walls
// moves much faster than its range over the duration) blur into none, so every chord of a ladder is
// used, shortest first: the longest and each half of the one before, down to `chord`. A kink is
// taken from the first chord that sees it (a later, longer chord's within ±w of it is the same
// kink), then located with the longest chord of the ladder whose fit window (±2w) holds no other
// kink. The running median spans at least 4w + 1 statistics. The sd has a floor for noise-free data
// (the flow's own curvature): the MAD of the residuals whose chords hold no kink found with a
// shorter chord (of all of them when fewer than a tenth are left). This works on the samples
// themselves: a first Savitzky–Golay pass over windows that span a jump smears the velocity's step
// over a whole window, so a detector on it sees a run of jumps instead of one.
//
// Derivatives: on each flow segment (between detected jumps, within a chain) a local polynomial of
// degree 2 (Savitzky–Golay on the samples' own times) over a window of m samples, centred on the
// sample where the segment allows and shifted at its ends, never across a jump. The slope at the
// window's centre has variance ≈ 12σ²/(m³δt²) (estimators.md §8): m is the smallest odd window ≥
// min_window whose slope sd is at most slope_precision × the segment's chord slope scale (its range
// over its duration), capped at the segment's length × max_window_share (the polynomial's bias
// grows with m).
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "core/model/model.hpp"

namespace hysid {

struct ReconstructOptions {
  double kink_threshold = 8.0;    // the statistic (in noise sd) above which a kink is a jump
  int chord = 4;                  // the shortest chord (samples) whose slopes the kink statistic compares
  double kink_precision = 0.2;    // > 0: the chord makes the statistic's sd at most this × the slope scale
  int median_window = 21;         // odd: the running median of Δs (the flow's curvature)
  int min_window = 5;             // odd, ≥ 3: the smallest Savitzky–Golay window
  double slope_precision = 0.01;  // > 0: the slope sd the window aims at, relative to the slope scale
  double max_window_share = 0.5;  // (0, 1]: the window's cap as a share of the segment's length
  // Raised (a signal handler, Python's Ctrl-C): DetectKinks and ReconstructStates return within
  // a few thousand samples' work, their result marked stopped (partial, not to be used). Null: never.
  const std::atomic<bool>* stop = nullptr;
  // Field-naming message, e.g. "ReconstructOptions::min_window = 2: must be odd and >= 3".
  bool IsValid(std::string* error) const;
};

// How each unmeasured state is reconstructed: from measured state source[i] as
// (dξ_source/dt − offset[i]) / scale[i] (source[i] = −1 for a measured state).
struct ReconstructionPlan {
  std::vector<int> measured;       // indices of the measured states, increasing
  std::vector<int> reconstructed;  // indices of the others, increasing
  std::vector<int> source;         // n entries
  Vec scale, offset;               // n entries
  std::string error;               // why a state cannot be reconstructed ("" when all can)
  bool ok() const { return error.empty(); }
};
// Throws std::invalid_argument for a measured index out of range or repeated.
ReconstructionPlan PlanReconstruction(const Model& model, const std::vector<int>& measured);

// The slope at t[k] of the degree-min(2, size − 1) least-squares polynomial through the samples
// (t[i], y[i]) for i in [first, first + size) (size ≥ 2).
double LocalSlope(const std::vector<double>& t, const double* y, long first, long size, long k);

// The Savitzky–Golay slope at every sample of [begin, end) from windows of `window` samples (odd)
// inside [begin, end): centred where they fit, shifted at the ends; a shorter range uses all of it
// (degree 1 for two samples, slope 0 for one).
void SavitzkyGolaySlope(const std::vector<double>& t, const double* y, long begin, long end, int window,
                        double* slope);

struct KinkDetection {
  std::vector<std::uint8_t> gamma;  // per sample: 1 = a jump in (t_{k−1}, t_k]
  std::vector<double> statistic;    // per sample (of the interval ending there), the largest over the chords
  Vec sigma;                        // the noise σ per measured component used
  long chord = 0;  // the longest chord a kink was located with (samples; the ladder's longest when none)
  bool stopped = false;             // ReconstructOptions::stop was raised: partial
};
// Kinks in y (m × K measured rows) at times t, chains cut at chain_start (empty: one chain); σ per
// row given (m entries) or, when empty, estimated (MAD of second differences).
KinkDetection DetectKinks(const std::vector<double>& t, const Mat& y, const std::vector<std::uint8_t>& chain_start,
                          const Vec& sigma, const ReconstructOptions& options);

struct Reconstruction {
  Mat x;                            // n × K: measured rows from y, the others reconstructed
  std::vector<std::uint8_t> gamma;  // the detected jumps (as KinkDetection)
  std::vector<double> statistic;
  Vec sigma;                        // per measured component (given or estimated)
  long chord = 0;                   // KinkDetection::chord (samples; the longest over chains)
  long segments = 0;                // flow segments over all chains
  int min_window = 0, max_window = 0;  // over the segments of three samples or more
  bool stopped = false;                // ReconstructOptions::stop was raised: partial
};

// The whole reconstruction of y (m × K, the measured rows in plan.measured's order). Throws
// std::invalid_argument for sizes that disagree, invalid options or a plan that is not ok.
Reconstruction ReconstructStates(const ReconstructionPlan& plan, const std::vector<double>& t, const Mat& y,
                                 const std::vector<std::uint8_t>& chain_start, const Vec& sigma,
                                 const ReconstructOptions& options = {});

}  // namespace hysid
