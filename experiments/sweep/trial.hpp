// One unit of a sweep: noisy samples of a shared noise-free trajectory, the identifier on them, and
// the metrics against the simulator's truth, as one row of trials.csv.
//
// The row is text (numbers with %.17g, empty for "not available") so that the journal, trials.csv and
// merged shards hold exactly the same bytes. A trial never throws for a numerical outcome: a
// simulation that did not complete (Zeno, solver failure, …), a non-finite estimate, or an exception
// inside the identifier becomes the row's `status` (and `message`) with empty metrics.
#pragma once

#include <atomic>
#include <optional>
#include <string>
#include <vector>

#include "core/identify/identifier.hpp"
#include "core/model/model.hpp"
#include "experiments/sweep/config.hpp"
#include "experiments/sweep/plan.hpp"
#include "sim/input_signal.hpp"
#include "sim/sensitivity/crlb.hpp"
#include "sim/simulator.hpp"

namespace hysid {

// Status values of a row.
inline constexpr const char* kTrialOk = "ok";
// With refine = ml: the refinement's status is not ok (refine_status, message say why). The row
// counts as a failure of its cell; alpha_hat / beta_hat hold the recursive estimate it kept.
inline constexpr const char* kTrialRefineFailed = "refine_failed";
// Without a refinement: the recursive flow estimate contradicts its data (flow_status inconsistent,
// message says why; core/identify/self_check.hpp). The row counts as a failure of its cell.
inline constexpr const char* kTrialInconsistent = "inconsistent";

// Prefix of the per-parameter error columns of trials.csv (summary.csv aggregates them too).
inline constexpr const char* kRelativeErrorPrefix = "rel_err_";
// Prefix of the per-parameter coverage columns of trials.csv (grid.refine): 1 when the truth lies in
// the refinement's reported 95 % interval θ̂ ± 1.96·se, 0 when not (summary.csv: the share per cell).
inline constexpr const char* kCoveragePrefix = "cover_";

// Columns of trials.csv for this sweep: identification, grid keys, x0, status, then the metrics
// (SummaryMetrics() among them), then α̂ and β̂ per unknown parameter name (union over the models), then
// rel_err_NAME = |θ̂ − θ| / |θ| per unknown parameter name (|θ̂ − θ| where the true θ is 0; α's names,
// then β's, a β name that is also an α name as rel_err_beta_NAME; empty where the row's model has no
// such unknown or the status is not ok).
// With grid.refine: `refine` after `detector`, and refine_status, crlb_e_alpha, crlb_e_beta (the
// cell's CRLB-implied mean errors at its σ over the whole record; empty for σ = 0), samples_used (the
// samples the estimate used: the refinement's samples_used with refine = ml, every sample with none;
// empty without an estimate), crlb_fit_e_alpha,
// crlb_fit_e_beta (the same over the samples the estimate used: the refinement's samples_used, a
// prefix of the record, with refine = ml, every sample with none; empty where the row is not ok)
// after flow_hull/jump_hull columns; and after the rel_err_* columns se_NAME (the refinement's
// standard error; empty where it did not run or is not ok) then cover_NAME (1 when |θ̂ − θ| ≤
// 1.96·se, else 0; empty without se) per unknown parameter, named as rel_err_*.
// When a model is a hybrid automaton (core/model/automaton.hpp), then: events_true, events_right (true
// events matched within one sample to a detected event assigned to their map), events_wrong_map
// (matched, another map), events_missed, events_spurious, event_time_error (the largest |t̂ − t| of
// the matched events over δt), and per jump map with unknown β e_beta_MAP (‖β̂ − β‖ over its unknown
// entries) and, with grid.refine, crlb_e_beta_MAP (its CRLB-implied mean error at the cell's σ).
std::vector<std::string> TrialHeader(const SweepConfig& config, const std::vector<Model>& models);

// The metric columns summary.csv aggregates (each must be in TrialHeader).
const std::vector<std::string>& SummaryMetrics();

// What the units of one (group, trial) share: the group's noise-free trajectory from `x0`, the
// trial's standard normals (n × K, the stream TrialNoiseKey; empty when no unit of the trial has
// σ > 0 or the simulation failed) and a buffer for the noisy samples y = x + σ·normals, kept while
// consecutive units have the same σ, with the identifier's flow regression rows of the samples at
// `rows_sigma` (σ = 0: the noise-free trajectory), built by the first unit that needs them, and the
// last unit's recursive identification with its cell: the next unit reuses it when its cell differs
// only in `refine` (refine varies fastest, so a refined cell's unit follows its recursive one's).
struct NoisySamples {
  Mat y;
  double sigma = 0.0;  // the σ of y; 0: y not filled
  FlowRows rows;
  double rows_sigma = -1.0;  // the σ of the samples `rows` belong to; −1: none
  IdentifyResult identified;
  std::optional<SweepCell> identified_cell;  // the cell `identified` ran for; empty: none
};
struct TrialInputs {
  const Vec* x0 = nullptr;
  const Trajectory* truth = nullptr;
  const Mat* normals = nullptr;
  NoisySamples* noisy = nullptr;
  std::string sim_error;  // non-empty: the simulator rejected the run (the row's status is "error")
  // With grid.refine: the group's CRLB at σ = 1 (its mean errors scale linearly with σ), or null.
  const Crlb* crlb = nullptr;
  // A model with inputs: the inputs the truth was simulated with (the model file's defaults at the
  // sample times), which the identifier and the refinement read at the samples; else null.
  const InputSignal* inputs = nullptr;
  // Raised: the refinement ends early (RefineOptions::stop); the caller drops the row. May be null.
  const std::atomic<bool>* stop = nullptr;
};

// The group's CRLB at σ = 1 for the model's unknowns (α, β, ξ0) over (x0, δt, t_end) with the
// inputs (may be null); never throws (a bad input becomes a not-ok status).
Crlb UnitCrlb(const Model& model, const Vec& x0, double dt, double t_end,
              const InputSignal* inputs = nullptr);

// A model with inputs: its default inputs at the samples of (δt, t_end) (InputsWithoutDefault's
// inputs refused by the model file's key); an empty signal for a model without inputs.
InputSignal DefaultInputs(const Model& model, double dt, double t_end);

// Runs unit `unit` = (cell, trial).
std::vector<std::string> RunTrial(const SweepConfig& config, const std::vector<Model>& models,
                                  const SweepCell& cell, long unit, long trial, const TrialInputs& in);

// Runs units `units` (unit i of cell *cells[i]) of one trial: the rows RunTrial gives each, in order,
// byte for byte. Units on the same samples (one model and σ) whose identifier feeds its samples in
// blocks are identified together (IdentifyLockstep, core/identify/lockstep.hpp); otherwise, or when
// that throws, one RunTrial after the other.
std::vector<std::vector<std::string>> RunTrials(const SweepConfig& config, const std::vector<Model>& models,
                                                const std::vector<const SweepCell*>& cells,
                                                const std::vector<long>& units, long trial, const TrialInputs& in);

// The shortest text that reads back as exactly v (fmt "{}"), or "" for NaN.
std::string FormatNumber(double v);

}  // namespace hysid
