// Which terms of a flow row do the data support: sparse selection among a model's candidate terms on
// the flow regression's integral rows (docs/method.md#which-model-candidate-terms), and of a jump row
// on the jump regression's rows of the detected jumps (SumJumps; #which-model-candidate-terms-of-a-jump).
//
// Rows. RegressionBuilder gives, per pair the recursive pass took for flow, the trapezoid row
// y_k = Δξ_r − Φ_{r,known} α_known, Φ_k = Φ_{r,unknown} (eq. 7). Within one flow segment (consecutive
// flow pairs of one chain) their running sums telescope, z_k = ξ_k − ξ_a = I_k α with I_k = Σ Φ_i,
// so each sample measures the integral with its own noise only (white residuals, unlike the
// trapezoid rows' differences); the segment's start is an offset per row, eliminated by centring
// (the `integral` estimator's rows). Per segment and row the centred sums are kept: G = Σ (I − Ī)(I − Ī)ᵀ,
// b = Σ (I − Ī)(z − z̄), s = Σ (z − z̄)², and the counts, so a subset of columns, a weighting of the
// rows or a bootstrap of segments is a sum of small matrices.
//
// Selection. Over the selectable columns (the candidates; the other unknowns are always kept):
// sequentially thresholded least squares (solve, zero the coefficients whose relative size
// |α_j|·√G_jj/√s is below λ, re-solve, until nothing changes) for a path of λ, backward
// elimination (drop the column of least |t|, re-solve), forward selection (add the column that
// leaves the least residual) and every support of at most SelectOptions::exhaustive candidates give
// supports; the first two start from the full fit, which on nearly dependent columns (polynomials of
// a state over a narrow range) puts large, arbitrary coefficients on them. The rule that picks one
// (SelectionRule): by default K-fold cross-validation over the segments, the fewest columns within one
// standard error of the least held-out mean square; or the least BIC = N log(RSS/N) + k log N (N the
// rows less the offsets, k the columns kept), which counts every row as independent: the noise of
// the regressors, integrated along a segment, is not, and BIC then keeps spurious terms.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/model/model.hpp"

namespace hysid {

// The centred sums of one identified row over one flow segment.
struct RowSums {
  Mat gram;             // p × p
  Vec cross;            // p
  double square = 0.0;  // Σ (z − z̄)²
  long count = 0;       // samples (the segment's anchor included)
};

struct SegmentSums {
  int chain = 0;              // the chain the segment lies in
  std::vector<RowSums> rows;  // one per identified flow row (RegressionLayout::Flow's order)
};

// The flow regression's integral sums per segment; `columns` are the unknown α indices, in the order
// of the sums' entries. The same form holds the jump regression's rows (SumJumps): one group per
// detected jump, its rows' sums not centred (a jump's rows have no offset to eliminate), `columns` the
// unknown β indices.
struct FlowSums {
  std::vector<int> columns;
  std::vector<SegmentSums> segments;
  bool centred = true;  // false: raw sums, no offset per group, no least group size (the jumps)
};

// Samples on the detected hybrid time domain. y: n × K states; gamma[k] = 1 where the pair (k−1, k)
// is a jump (IdentifyResult::gamma); times: per sample (empty: uniform with step dt); chain_start:
// 1 where a chain starts (empty: one chain); inputs: m × K (empty: none); modes: per sample its mode
// (IdentifyResult::mode; empty: every sample in mode 0). Only the pairs with both samples in `mode`
// are summed, φ of that mode; a pair of another mode, like a non-finite sample, ends a segment. A
// switch's detected place is uncertain (a kink is located by fits to windows of samples on either
// side): the samples within `margin` samples of a mode change are left out (a segment ends there).
struct FlowSamples {
  const Mat* y = nullptr;
  const std::vector<std::uint8_t>* gamma = nullptr;
  double dt = 0.0;
  const std::vector<double>* times = nullptr;
  const std::vector<std::uint8_t>* chain_start = nullptr;
  const Mat* inputs = nullptr;
  const std::vector<int>* modes = nullptr;
  int mode = 0;
  int margin = 0;
};

// Throws std::invalid_argument on sizes that disagree.
FlowSums SumFlowSegments(const Model& model, const FlowSamples& samples);

// The jumps on the detected hybrid time domain: the pairs (k − 1, k) with gamma[k] = 1 within a chain
// and both samples finite. Fields as FlowSamples'; ψ at the pre-jump sample's context (its time and
// inputs). A model with [[jump]] maps needs `maps`: per sample k the map of the jump between k − 1 and
// k (−1: none; IdentifyResult::events' assignments), and sums only the jumps of map `map`, ψ_map at
// the pre-jump sample (std::invalid_argument without them).
struct JumpSamples {
  const Mat* y = nullptr;
  const std::vector<std::uint8_t>* gamma = nullptr;
  double dt = 0.0;
  const std::vector<double>* times = nullptr;
  const std::vector<std::uint8_t>* chain_start = nullptr;
  const Mat* inputs = nullptr;
  const std::vector<int>* maps = nullptr;
  int map = 0;
};

// The jump regression's rows (RegressionBuilder::Jump: y = ξ_r⁺ − Ψ_{r,known}(ξ⁻) β_known on
// Ψ_{r,unknown}(ξ⁻)), one group per jump with one row per identified jump row, not centred.
FlowSums SumJumps(const Model& model, const JumpSamples& samples);

// The sums on the columns `keep` (positions in sums.columns, ascending) only, less the rows in which
// none of them is nonzero (a mode's columns: those whose sums are not all zero, ColumnsInUse).
FlowSums KeepColumns(const FlowSums& sums, const std::vector<int>& keep);
// The positions of the columns with a nonzero Gram diagonal in some segment and row: φ of the summed
// mode has them (the other modes' candidates are exactly 0 there).
std::vector<int> ColumnsInUse(const FlowSums& sums);

// How the support is chosen among those of the path.
enum class SelectionRule {
  kCrossValidation,  // fewest columns within one standard error of the least held-out mean square
  kBic,              // least BIC
};

struct SelectOptions {
  SelectionRule rule = SelectionRule::kCrossValidation;
  int folds = 5;         // cross-validation: segment i is held out in fold i mod folds (0: one per segment, leave-one-out)
  int thresholds = 40;   // λ values on the STLSQ path (log-spaced over the relative coefficients)
  int iterations = 20;   // at most per STLSQ run
  int min_segment = 3;   // segments with fewer samples are left out (centred sums only)
  double min_share = 0.5;  // [0, 1]: KeepStable drops a chosen candidate the bootstrap chose less often
  int exhaustive = 2;      // [0, 3]: every support of at most this many candidates is compared too
  bool IsValid(std::string* error) const;
};

struct Selection {
  bool ok = false;
  std::string reason;          // why not ok
  std::vector<bool> chosen;    // per column of FlowSums::columns
  Vec estimate;                // least squares on the chosen columns (0 elsewhere)
  double bic = 0.0;            // of the chosen support
  double cv = 0.0;             // its held-out mean square (cross-validation; 0 with kBic)
  double runner_up_bic = 0.0;  // the least BIC of another support (infinity when none)
  std::vector<bool> runner_up;
  long rows = 0;               // N: rows less offsets
  int supports = 0;            // distinct supports compared
};

// `selectable[j]`: column j may be dropped. `multiplicity` (empty: 1 each): how often each segment
// counts (a bootstrap draw).
Selection SelectTerms(const FlowSums& sums, const std::vector<bool>& selectable, const SelectOptions& options,
                      const std::vector<int>& multiplicity = {});

// How often each column is chosen over `draws` resamples of the segments with replacement (drawn from
// std::mt19937_64 seeded by (seed, draw)); a draw whose selection fails counts as no choice.
struct BootstrapResult {
  Vec frequency;   // per column, in [0, 1]
  int draws = 0;   // draws whose selection was ok
  int support_matches = 0;  // draws that chose exactly `reference`'s support
};
BootstrapResult BootstrapSelection(const FlowSums& sums, const std::vector<bool>& selectable,
                                   const SelectOptions& options, int draws, std::uint64_t seed,
                                   const std::vector<bool>& reference);

// The chosen support less its unstable candidates (stability selection, Meinshausen and Bühlmann
// 2010, on the bootstrap of the segments): a selectable column that `selection` chose but fewer than
// options.min_share of the bootstrap's draws did is dropped, and the kept columns refitted (their
// least squares, BIC and held-out mean square; the runner-up becomes the cross-validated support).
// `selection` as it is when nothing is dropped, when it
// is not ok, when the bootstrap has no draws, or when the kept columns are dependent. Throws
// std::invalid_argument on sizes that disagree and invalid options.
Selection KeepStable(const FlowSums& sums, const std::vector<bool>& selectable, const Selection& selection,
                     const BootstrapResult& bootstrap, const SelectOptions& options);

}  // namespace hysid
