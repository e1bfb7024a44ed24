// A repaired start for the output-error refinement, from the recursive α̂ and the detected jumps.
//
// Used when the fit from the recursive estimate on the detected segments fails. Around each
// detected jump, the flow with α̂ is fit by least squares to a window of samples on each side (the
// state at one sample of the window is the unknown; forward with α̂, backward as the forward flow of
// −α̂, guard crossings ignored), and to the two windows as one flow:
// - a detection where the single flow fits nearly as well (χ² gain of the split below
//   `split_threshold`) is dropped (a false alarm: it cut a flow in two, which no model reproduces);
// - a kept detection moves to the sample within `search` samples where the two fitted flows meet
//   best (the detector localises a jump up to a few samples);
// - β (its unknown entries) is re-estimated by linear least squares ψ(ξ⁻)β = ξ⁺ on the identified
//   jump rows, ξ⁻ and ξ⁺ the two fitted flows at the samples before and after each kept jump, and
//   ξ0 is the fitted flow of the first window at sample 0 (the recursive β̂ leans on the raw samples
//   around each detection, and a false detection's row can ruin it);
// - a jump that the model started from the repaired values makes inside a segment, with no detection
//   within `search` samples (a detector that missed a jump), is tested in the same way and kept
//   when the data show it.
// Nothing here decides the status: the refinement fits from the repaired start and checks the fit
// as usual.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "sim/sensitivity/sensitivity.hpp"

namespace hysid {

struct StartRepairOptions {
  long window = 200;              // samples on each side of a detection fit by the local flows
  long min_window = 10;           // detections closer than this are one jump; a missed jump is looked
                                  // for this far from the segment's ends
  long search = 10;               // a detection moves by at most this many samples at a time
  long predicted_search = 50;     // the same for a jump the model makes where none was detected
  double split_threshold = 50.0;  // χ² gain (Σ (r/σ)²) of a jump over one flow below which it is dropped
  int max_iterations = 20;        // Ceres iterations of one local fit
  int max_rounds = 4;             // rounds of looking for missed jumps
};

struct StartRepair {
  bool ok = false;  // false: no usable repair (message says why)
  std::string message;
  std::vector<std::uint8_t> gamma;  // the repaired jump labels
  HybridParameters start;           // α̂, the re-estimated β and ξ0
  int dropped = 0, moved = 0, added = 0;
  // The rows of the β regression ψ(ξ⁻)β = ξ⁺ behind start.beta (columns: β's unknown entries; right
  // side: less the known entries), for pooling several chains of one system (SolveJumpRows).
  Mat jump_rows;
  Vec jump_rhs;
  std::string Summary() const;  // "dropped 1 detection, moved 0, added 0; β, ξ0 re-estimated"
};

// weight: 1/σ_i per component; options: the integration options of the fit.
StartRepair RepairStart(const Model& model, const Mat& y, double dt, const std::vector<std::uint8_t>& gamma,
                        const HybridParameters& recursive, const Unknowns& unknowns, const Vec& weight,
                        const SensitivityOptions& options, const StartRepairOptions& repair = {});

// The start of the guard parameters γ from the detected jumps (docs/architecture.md, "Refinement"):
// for each detected jump at sample k (labels[k] = 1, k ≥ 1), the pre-jump sample moved half a step
// along the flow, x̃ = y_{k−1} + ½ (t_k − t_{k−1}) φ(y_{k−1}) α, lies on the guard that fired, on
// average over where in (t_{k−1}, t_k] the jump fell. Its row of h(x̃, γ) = 0 linearised at γ0 (the
// guard whose |h(x̃, γ0)| is least; ∂h/∂γ by Model::GuardGammaJacobian) is appended to rows/rhs, so
// that one Newton step from γ0 over the jumps of every chain is their least-squares solution
// (SolveGuardRows). Columns: γ's unknown entries. Samples with a non-finite entry give no row.
// A hybrid automaton with the events assigned (`maps`: one per label, in order; RefineChain::maps):
// each event's row is its own map's guard, the flow in the mode it leaves (from `initial_mode`,
// then ModeAfter); `maps` empty: the nearest guard, the flow in mode 0. A model with inputs: u holds
// them at each sample (m × K), the flow and guards read them at the pre-jump sample.
void AppendGuardRows(const Model& model, const std::vector<double>& t, const Mat& y,
                     const std::vector<std::uint8_t>& labels, const Vec& alpha, const Vec& gamma0,
                     const Unknowns& unknowns, Mat* rows, Vec* rhs, const std::vector<int>& maps = {},
                     int initial_mode = 0, const Eigen::Ref<const Mat>& u = Mat());

// γ0 with its unknown entries moved by the least-squares Newton step of the rows; an unknown entry no
// row involves (its column zero), or all of them when the rows are rank-deficient, stays at γ0.
Vec SolveGuardRows(const Unknowns& unknowns, const Mat& rows, const Vec& rhs, const Vec& gamma0);

// β with its unknown entries the least-squares solution of the regression rows (StartRepair's, or
// several stacked); `beta` unchanged when the rows are fewer than the unknowns or rank-deficient.
Vec SolveJumpRows(const Unknowns& unknowns, const Mat& rows, const Vec& rhs, const Vec& beta);

// Starts spread over the box a far start spans: `count` points of the Halton sequence (bases the first
// primes, its point k = 1 … count) in the unknown α and β entries, entry i of point k at
// center_i · factor^(2 h_ki − 1) (h_ki the radical inverse of k in the i-th prime base), so within a
// factor `factor` of the center either way; clamped into the entries' bounds. An entry whose center
// is 0 stays 0. The other entries (known ones, γ, x0) are the center's.
std::vector<HybridParameters> DesignStarts(const Model& model, const HybridParameters& center, int count,
                                           double factor);

}  // namespace hysid
