// Metrics of an identification run against the simulator's ground truth.
#pragma once

#include <cstdint>
#include <vector>

#include "core/detectors/detector.hpp"
#include "core/identify/automaton_event.hpp"
#include "core/model/model.hpp"

namespace hysid {

// Per-sample confusion of γ against the truth; sample k ≥ 1 is a true jump when a jump happened in
// (t_{k−1}, t_k], i.e. j_k ≠ j_{k−1}. Sample 0 is not scored.
struct Confusion {
  long tp = 0, fp = 0, fn = 0, tn = 0;
  long total() const { return tp + fp + fn + tn; }
  double misclassification() const;  // (fp + fn) / total (0 when total = 0)
  double precision() const;          // tp / (tp + fp); 1 when nothing was flagged
  double recall() const;             // tp / (tp + fn); 1 when there was nothing to find
};
// Throws std::invalid_argument when the sizes differ.
Confusion CompareJumps(const std::vector<int>& j_true, const std::vector<std::uint8_t>& gamma);

struct ParameterErrors {
  double e_alpha = 0.0, e_beta = 0.0;      // ‖α − α̂‖, ‖β − β̂‖ (full vectors)
  double rel_alpha = 0.0, rel_beta = 0.0;  // over the unknown entries: ‖α_u − α̂_u‖/‖α_u‖
};
ParameterErrors CompareParameters(const Model& truth, const Vec& alpha_hat, const Vec& beta_hat);

// A true event of a hybrid automaton: the first sample after it, its instant and its jump map.
struct TrueEvent {
  long sample = 0;
  double time = 0.0;
  int map = 0;
};

// The true events matched to the detected ones one to one, nearest sample first, within one sample.
// counts[t][a]: t the true map (the last row, `maps`: no true event, a spurious one), a the assigned
// map (the last column: no detected event, a missed one; a map outside [0, maps) counts there too).
// max_time_error: the largest |t̂ − t| over the matched events (AutomatonEvent::time against
// TrueEvent::time; 0 when none matched).
struct EventComparison {
  std::vector<std::vector<long>> counts;
  long true_events = 0, detected = 0, right = 0, missed = 0, spurious = 0;
  double max_time_error = 0.0;
  long wrong_map() const { return true_events - missed - right; }  // matched to another map's event
};
EventComparison CompareEvents(int maps, const std::vector<TrueEvent>& truth,
                              const std::vector<AutomatonEvent>& events);

// The largest |t̂ − t| over the true events, t̂ the time of the nearest event of `fitted` (a fitted
// model's guard crossings; their `sample` is not read) that applies the same map, or of any map when
// none does; NaN when `fitted` is empty and `truth` is not, 0 when `truth` is empty.
double LargestNearestTimeError(const std::vector<TrueEvent>& truth, const std::vector<TrueEvent>& fitted);

// The smoothness bound τ(t) of eq. (2)–(3) with the true flow: (1/2)·L·(‖ξ(t)‖ + ‖ξ(t−δt)‖) with the
// bound mode of `settings` (paper / homogeneous) and L from the true α over the true states.
// One value per sample (τ[0] = 0). e_τ(t) = |τ̂(t) − r·τ(t)|.
std::vector<double> TrueSmoothnessBound(const Model& model, const Mat& x_true,
                                        const DetectorSettings& settings);

}  // namespace hysid
