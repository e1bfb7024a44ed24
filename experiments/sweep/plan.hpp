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
  int model = 0;  // index into SweepConfig::models
  double dt = 0.0;
  double sigma = 0.0;
  // One value per SweepGrid::options axis; NaN when neither the estimator nor the detector reads it.
  std::vector<double> options;
  EstimatorKind estimator = EstimatorKind::kRls;
  DetectorKind detector = DetectorKind::kPaper;
  std::string refine = "none";  // grid.refine: "none" or "ml"

  // The value of the axis named `name` (NaN when unused); throws std::invalid_argument for no such axis.
  double option(const SweepGrid& grid, std::string_view name) const;
  // The cell's estimator, detector and axis values set on `settings`.
  void Apply(const SweepGrid& grid, IdentifierSettings* settings) const;
};

// Whether the estimator or the detector of a cell reads the option of `axis`.
bool Reads(const OptionAxis& axis, EstimatorKind estimator, DetectorKind detector);

// Cells in the order model, δt, σ, the option axes (in SweepGrid::options order), estimator, detector
// (the last varies fastest). A (estimator, detector) pair appears once for each value of the axes it
// reads, at the first value of the others.
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
