// What a sweep runs: its cells (one per combination of the grid), its units (cell, trial), and the
// groups of units that share one noise-free trajectory (same model, δt and x0).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/model/model.hpp"
#include "experiments/sweep/config.hpp"
#include "sim/measurement.hpp"

namespace hysid {

struct SweepCell {
  long index = 0;
  int model = 0;      // index into SweepConfig::models
  double dt = 0.0;
  double sigma = 0.0;
  double r = 0.0;     // NaN when the detector does not use r
  double false_alarm = 0.0;  // NaN when the detector does not use it
  std::string estimator, detector;
};

// Detectors whose decision depends on r (others get one cell with r = NaN).
bool DetectorUsesR(const std::string& detector);
// Detectors whose decision depends on the false-alarm probability.
bool DetectorUsesFalseAlarm(const std::string& detector);

// Cells in the order model, δt, σ, r, false_alarm, estimator, detector (the last varies fastest).
std::vector<SweepCell> EnumerateCells(const SweepConfig& config);

// A unit's id is cell·trials + trial.
struct UnitId {
  long cell = 0, trial = 0;
};
inline long UnitIndex(const UnitId& u, long trials) { return u.cell * trials + u.trial; }
inline UnitId UnitOf(long id, long trials) { return {id / trials, id % trials}; }

// --shard K/N: units with id mod N = K − 1. {1, 1} is the whole sweep.
struct Shard {
  long k = 1, n = 1;
  bool Contains(long unit) const { return unit % n == k - 1; }
  std::string ToString() const;
};
// Parses "K/N" (1 ≤ K ≤ N). Throws std::invalid_argument naming --shard.
Shard ParseShard(const std::string& text);

// Units sharing one noise-free trajectory: (model, δt, x0). x0 is fixed unless drawn per trial
// (then `x0_trial` is the trial whose draw it is, else −1).
struct TrajectoryGroup {
  int model = 0;
  double dt = 0.0;
  long x0_trial = -1;
  std::vector<long> units;  // ascending
};

// The groups covering `units` (ascending ids), in a deterministic order.
std::vector<TrajectoryGroup> GroupUnits(const SweepConfig& config, const std::vector<SweepCell>& cells,
                                        const std::vector<long>& units);

// The measurement noise of trial `trial` in the group (model, δt): the stream keyed by (master seed,
// stream = trial, sub = (model, bit pattern of δt)). Every cell of the group draws the same standard
// normals for one trial and scales them by its σ (common random numbers); a drawn x0 is a function
// of (seed, trial, model), so the key fixes it too.
NoiseKey TrialNoiseKey(const SweepConfig& config, int model, double dt, long trial);

// The units of `group` in runs of one trial each: ascending trial, units ascending within a run.
std::vector<std::vector<long>> UnitsByTrial(const TrajectoryGroup& group, long trials);

// The initial state of trial `trial` of model `model`: the fixed x0, or a uniform draw in x0_range
// keyed by (master seed, stream = trial, counter = model).
Vec InitialState(const SweepConfig& config, int model, long trial);

}  // namespace hysid
