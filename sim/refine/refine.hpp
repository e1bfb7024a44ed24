// Maximum-likelihood (output-error) refinement of a recursive estimate, on one or several chains of
// samples of one system (a uniform run is one chain; several runs, or a run cut at gaps, are several).
//
// Minimises Σ_c Σ_k Σ_{i measured} ((y_cik − ξ_i(t_ck; θ, ξ0_c))/σ_i)² over θ = (unknown α, β and guard
// parameters γ), shared by the chains, and one initial state ξ0_c per chain (its own Ceres parameter
// block, eliminated by the
// Schur complement). Each chain is simulated from its own initial state on its own sample times,
// read on the hybrid time domain of its detected jumps: sample k is compared with the model's
// segment j_k = Σ_{l≤k} γ_l, each segment's flow continued past the model's next jump and before its
// own start (SimulateSensitivitiesMatched), so no residual jumps as θ moves. (Plain residuals stall
// far from the optimum: samples that change side of a moving jump time dominate the cost.) Start:
// the recursive α̂, β̂, γ from the detected jumps (one Newton step of the guard at the pre-jump
// samples moved half a step along the flow, sim/refine/start.hpp) and each chain's first sample;
// a start outside a parameter's bounds starts on the bound. Solver: Ceres, Levenberg–Marquardt
// with the parameters' finite bounds, Jacobian −S_k/σ_i from the hybrid forward sensitivities.
//
// The result is checked, and its status is not ok (the recursive estimate is then kept) when:
// the data are not finite, there are too few samples, the start does not simulate, Ceres does not
// converge, the fitted model run on its own over a chain is Zeno or its jump count or jump times
// disagree with the detector's, the Fisher information is singular, the normalised residual RMS is
// refused by its test (σ estimated: the residual σ̂ above rms_high × the MAD estimate), or the
// residuals' lag-1 autocorrelation within chains is refused by its test (when they are above the
// integration accuracy); both tests at the stated size residual_test_size. Never NaN. Messages name the chain when there are several.
// A fit whose jumps disagree with a chain's detected ones (count or times) is first tried again
// with that chain's detections mended from the fitted model: a jump the model makes with no
// detection within jump_time_tolerance + 1 samples is added at its sample, a detection the model has
// no jump for is dropped, the others kept; the fit from the fitted point on the mended detections
// (mended again from its own model while its jumps disagree with them, at most 4 fits) is adopted
// when it passes every check (the data decide) and fits as many samples, once per chain
// (`mended` says what changed). A jump-count mismatch or a failed start of one chain is then retried with
// that chain's span ending before the first disagreement between its model's jumps and its detected ones
// (RefineOptions::max_span_retries); a fit then ok only on cut spans is carried to all samples with the
// jumps its model makes far from every detection added, when that fit passes every check (sim/refine/mend.hpp).
// A fit that still fails (other than for the data or their length), or is ok only on spans the
// retries cut, goes on along the routes of RefineRoute in their order (RefineOptions::routes): a
// repaired start (sim/refine/start.hpp, per chain: detections the local flows do not need dropped,
// the others moved to where the flows meet, missed jumps added, ξ0_c re-estimated; β from all
// chains' jump regressions pooled), a span grown from a short one, multiple shooting between detected
// jumps (a route to the same single-shooting fit: same cost, checks and covariance), then multiple
// shooting by time (not when ModelJumpsUnresolved, sim/refine/span.hpp, after a fit ok on cut spans);
// each route's fit is adopted by its own rule, and RefineResult::route names the route of the fit reported.
#pragma once

#include <algorithm>
#include <atomic>
#include <initializer_list>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/identify/identifier.hpp"
#include "sim/refine/sample_view.hpp"
#include "sim/refine/start.hpp"
#include "sim/sensitivity/crlb.hpp"

namespace hysid {

enum class RefineStatus {
  kOk,
  kNonFiniteData,        // a chain's y has a NaN or an infinity
  kTooFewSamples,        // no chain long enough, or fewer samples than unknowns / n + 2
  kStartFailed,          // the start does not simulate on the detected segments
  kNotConverged,         // Ceres stopped without convergence (iteration budget, failed steps)
  kZeno,                 // the fitted model is Zeno within a chain's span, or its jumps accumulate
                         // faster than the samples (more jumps than detected, the last ones less
                         // than a sample apart)
  kJumpCountMismatch,    // the fitted model's jump count or jump times disagree with the detector's
  kSingularFisher,       // some direction of θ is not identifiable at the fit
  kResidualRms,          // normalised residual RMS far from 1: the fit (or σ) is wrong
  kResidualCorrelation,  // residuals not white: the model or the segmentation is wrong
};
const char* ToString(RefineStatus status);

// The refinement's routes, in the one order they are tried: each after the ones before it while
// their fit is not ok (or is ok only on spans the retries cut), under the rule each states.
enum class RefineRoute {
  // Single shooting on the detected labels (always tried first): the fit from the recursive start,
  // with the span retries and the detections mended from the fitted model (mend_detections).
  kLabels,
  // The same from a repaired start (see above; not for a model with inputs); adopted when ok (and it
  // fits more samples).
  kRepairedStart,
  // Grown from a short span: the samples before each chain's third detected jump, then half as many
  // again at each step, from the previous fit with the labels of the grown part mended from its model
  // (the fits on short spans with 1.5 × jump_time_tolerance); adopted when its fit on all samples
  // passes every check (it fits more samples).
  kGrownSpan,
  // Multiple shooting between detected jumps (sim/refine/shooting.hpp; only while not ok: one ok on
  // spans the retries cut stands): each chain cut into segments of shooting_jumps detected jumps (and
  // no longer than shooting_jumps + 1 median intervals between them), each with its own free initial
  // state, consecutive segments linked by continuity residuals; the segments' labels mended from
  // their own models; then the chains by single shooting from that fit's point, adopted when ok on
  // all samples (`mended` then begins "multiple shooting over S segments").
  kSegmentShooting,
  // Multiple shooting with nodes placed by time, the model finding its own events
  // (sim/refine/time_shooting.hpp), from the recursive start, from the model's own values, for a
  // hidden mode from α of the modes the data show, and while no fit of any route can be reported (or
  // the one reported is refused although its free segments fit the data to the noise), from the
  // model's values with its guards reached and from a design over their box
  // (TimeShootingFromStarts in refine.cpp); tried once after the best initial mode's routes, and
  // adopted when ok, or when it converged and nothing else did (its residual tests then refuse it,
  // the estimates stand with sandwich standard errors).
  kTimeShooting,
};
// "single shooting on the detected labels", "repaired start", "grown from a short span",
// "multiple shooting", "multiple shooting by time": the names `RefineResult::route` records.
const char* ToString(RefineRoute route);
// Every route, in order; and every route but `dropped` (kLabels cannot be dropped).
std::vector<RefineRoute> AllRefineRoutes();
std::vector<RefineRoute> RefineRoutesWithout(std::initializer_list<RefineRoute> dropped);

struct RefineOptions {
  // Integration of the fits: budgets, the Zeno rule, and the loosest tolerances (rtol = atol) used.
  // The fits integrate at rtol = atol = noise_tolerance · min_i σ_i / max(1, max_k |y_ik|) (σ given or
  // the MAD estimate), clamped to [polish_tolerance, sensitivity.sim.rtol]: an integration error far
  // below the noise changes the estimate by a negligible fraction of its standard error.
  SensitivityOptions sensitivity = [] {
    SensitivityOptions s;
    s.sim.rtol = 1e-6;
    s.sim.atol = 1e-6;
    return s;
  }();
  double noise_tolerance = 1e-4;
  // Residuals at the integration accuracy after the fit (noise-free data): a second fit from there at
  // rtol = atol = polish_tolerance (no polish when it is not below the tolerances above).
  double polish_tolerance = 1e-12;
  int max_iterations = 50;
  double function_tolerance = 1e-9;   // Ceres: relative cost decrease
  double parameter_tolerance = 1e-9;  // Ceres: relative step
  // The measured states (indices, increasing): the residuals are y − Hξ over these rows only, and the
  // chains' other rows (a reconstruction, core/identify/reconstruct.hpp) are only a start (ξ0_c, the
  // repaired start). Empty: every state is measured.
  std::vector<int> measured;
  // Components of ξ0 that are known (indices, increasing), held at their values in x0 (n entries; the
  // others ignored) and left out of the covariance (standard error 0). One chain only.
  std::vector<int> x0_known;
  Vec x0;
  Vec sigma;  // per measured component (≥ 0; n entries when all are measured) when known; empty: estimated
  // The size of the residual tests that make a fit ok (sim/refine/residual_tests.hpp): the
  // probability that a fit at the noise is refused, half for the level Σ(r/σ)² against χ²_{N−p} (σ
  // given), half for the lag-1 autocorrelation within chains (√N ρ̂₁ against the normal law).
  double residual_test_size = 0.01;
  double rms_high = 1.25;  // σ estimated: residual σ̂ ≤ rms_high × MAD σ̂ (core/model/noise_shape)
  double jump_time_tolerance = 3.0;  // samples (of the detected interval's own step)
  // Detected jumps closer than this many samples are not resolved reliably (a bouncing ball nearing
  // its Zeno time): the samples before the first such jump are fit (RefineResult::samples_used).
  // 0: always all samples.
  long min_jump_interval = 50;
  // When a chain's (start or fitted) model's jumps disagree with its detected ones (jump-count
  // mismatch or start failure), that chain's span is cut to end ceil(jump_time_tolerance) + 2
  // samples before the first disagreement and the chains fit again, at most this many times per
  // chain (0: never).
  int max_span_retries = 3;
  // A fit whose jumps disagree with a chain's detected ones is tried again with that chain's
  // detections mended from the fitted model (see above); false: never.
  bool mend_detections = true;
  // The routes tried (RefineRoute), in AllRefineRoutes' order, kLabels first; a route left out is
  // never tried (an automaton skips kRepairedStart, kGrownSpan and kSegmentShooting: they regress one
  // jump map and cut labels without maps).
  std::vector<RefineRoute> routes = AllRefineRoutes();
  bool tries(RefineRoute route) const { return std::find(routes.begin(), routes.end(), route) != routes.end(); }
  int shooting_jumps = 2;  // kSegmentShooting: detected jumps per segment
  StartRepairOptions start_repair;
  // Raised (by another thread: Ctrl-C in the Python module): the solve ends at its next iteration and
  // nothing more is tried (the result is then not ok). Null: never.
  const std::atomic<bool>* stop = nullptr;
  // A second such flag, raised when the fit is no longer needed (a later start of a search whose
  // earlier start has ended it): either flag ends the fit. Set for the runs too (sensitivity.sim).
  const std::atomic<bool>* cancel = nullptr;
  bool stopped() const { return (stop != nullptr && stop->load()) || (cancel != nullptr && cancel->load()); }
  // Field-naming message, e.g. "RefineOptions::residual_test_size = 2: must be in (0, 0.5)".
  bool IsValid(std::string* error) const;
};

struct RefineResult {
  RefineStatus status = RefineStatus::kOk;
  std::string reason;  // why the status is not ok ("" when ok)
  bool ok() const { return status == RefineStatus::kOk; }
  // The refined point stands as the estimate with its covariance: ok, or a converged fit whose
  // residuals the tests refuse (model error: the covariance is then the sandwich's).
  bool reported = false;
  std::string route;  // the route whose fit this is
  // Multiple shooting by time: its nearly free first stage fit the data to the noise on most segments
  // (the median segment's mean squared weighted residual at most kSegmentNoiseRatio = 2), so the model
  // can follow the data segment by segment; a fit that ends refused after that sits in a local minimum
  // rather than showing model error.
  bool segments_fit_noise = false;
  // The fit's residual tests pass, also when its information is singular (singular-fisher): a fit
  // at the noise on every sample whose information is singular is not bettered by another start.
  bool at_the_noise = false;
  // Every route tried, in order, with its outcome ("single shooting on the detected labels: ok on 257
  // of 365 samples", "multiple shooting by time: residual-correlation").
  std::vector<std::string> routes_tried;
  // θ's entries reported: the unknown α, β and γ entries and the first fitted chain's initial state
  // (all chains' initial states are in chain_x0).
  std::vector<std::string> names;
  Unknowns unknowns;
  HybridParameters start;     // the recursive estimate, x0 = the first fitted chain's first sample
  HybridParameters refined;   // Ceres' final point (equal to start when it did not run)
  HybridParameters estimate;  // refined when ok, else start
  // At the refined point when ok (else empty): the block of F(θ̂)⁻¹ for `names` (F the joint
  // information of α, β and every chain's initial state) with σ (given, or from the residuals), and
  // its square-rooted diagonal.
  Mat covariance;
  Vec standard_errors;
  // singular-fisher at the noise (at_the_noise): the refined point fits the data, one direction of θ
  // is not determined. Per entry of `names`, the standard error at `refined` of each one the data
  // determine (DeterminedSd of the information with σ), NaN for the others; empty otherwise, and
  // when the information has more than kMaxDeterminedSize rows.
  Vec determined_standard_errors;
  static constexpr int kMaxDeterminedSize = 500;
  Vec sigma;  // σ used for the covariance (n; 0 for an unmeasured state)
  bool sigma_estimated = false;
  double normalized_rms = 0.0;  // σ given: RMS of r/σ; estimated: max_i σ̂_i / MAD σ̂_i
  double lag1 = 0.0;            // lag-1 autocorrelation of the normalised residuals within chains
  int iterations = 0;
  double initial_cost = 0.0, final_cost = 0.0;  // ½ Σ (r/σ_w)² with the weighting σ
  long samples_used = 0;     // samples fit, over all chains (see RefineOptions::min_jump_interval)
  std::string span_reason;   // why samples were left out ("" when all are fit; "chain c: …" when several)
  // Measured values left out of the final solve and of its tests and information (multiple shooting
  // by time): beside a fitted jump, farther than kTrim robust sd from the model, i.e. on the jump's
  // other side (a jump time within its uncertainty may fall on either side of a sample).
  long left_out = 0;
  int detected_jumps = 0;    // in the fitted spans (of the repaired detections when start_repair is set)
  std::string start_repair;  // what the repaired start changed, when the result comes from it ("" else)
  std::string mended;        // the detections mended from the fitted model ("" when none)
  int model_jumps = -1;      // of the fitted model on its own over the fitted spans (−1: not simulated)
  // Per chain (the caller's order): the initial state fitted (start: its first sample; empty for a
  // chain left out), the samples fit (0: left out) and why the others were left out ("" when all
  // were fit); how many chains were fit and how many left out (too short, or their first sample
  // outside C ∪ D).
  std::vector<Vec> chain_x0;
  std::vector<long> chain_samples_used;
  // Per chain, the mode its fitted initial state is in, when the fit chose it (multiple shooting by
  // time; empty: each chain's own RefineChain::initial_mode, else initial_mode).
  std::vector<int> chain_mode;
  // Per chain (the caller's order), beside `covariance`: the covariance of the shared unknowns and
  // that chain's initial state (chain_x0), ordered as `names`; the first fitted chain's is
  // `covariance`. Empty for a chain left out, and all empty when there is no covariance.
  std::vector<Mat> chain_covariance;
  // chain_covariance[c] when it is there (θ and chain c's ξ0 of an n-state model), else null.
  const Mat* covariance_of_chain(std::size_t c, int n) const {
    return c < chain_covariance.size() && chain_covariance[c].rows() == unknowns.size(n) ? &chain_covariance[c]
                                                                                           : nullptr;
  }
  // A hybrid automaton: the mode the chains with an unknown initial mode were fit from (the candidate
  // of lowest final cost among the ok fits, else of the first; the given one, or the model's
  // default_mode, when none is unknown) and, when candidates were tried, each one's outcome
  // ("off: cost 1234.5; on: jump-count-mismatch").
  int initial_mode = -1;
  std::string mode_search;
  std::vector<std::string> chain_span_reason;
  long chains_used = 0, chains_skipped = 0;
  // Multiple shooting by time: gaps the model was run through (chains of one run fitted as one
  // trajectory, RefineChain::after_gap); chains_used counts the chains before joining.
  long gaps_joined = 0;
};

// One chain of samples: consecutive samples of one run (a missing sample inside a chain is simply
// absent from its times). y and u view samples held elsewhere: the caller's arrays (SplitChains) or
// the chain's own copy (`owned`, shared by the chain's copies: Of, Uniform, a chain with a missing
// sample).
struct RefineChain {
  std::vector<double> t;            // sample times, increasing (any origin)
  SampleView y;                     // n × K
  std::vector<std::uint8_t> gamma;  // 1 = a jump detected in (t_{k−1}, t_k]; gamma[0] is ignored
  // A model with inputs: u at each sample (m × K, finite); the fits run the model with u
  // interpolated linearly between the samples (sim/input_signal.hpp). No rows without inputs.
  SampleView u;
  // A hybrid automaton (core/model/automaton.hpp): the jump map assigned to each detected event of
  // the chain, in order (one per gamma = 1; empty: not assigned, the jump check counts events only),
  // and the mode at its first sample (−1: unknown, each mode is tried).
  std::vector<int> maps = {};
  int initial_mode = -1;
  // The chain continues the one before it in the same run after a gap (a step longer than the data's
  // max_gap): multiple shooting by time simulates the run through the gap, one trajectory.
  bool after_gap = false;
  // The samples y and u view when the chain holds them itself (null: they are the caller's).
  struct Samples {
    Mat y, u;
  };
  std::shared_ptr<const Samples> owned;
  // A chain holding its own samples (y: n × K, u: m × K or empty).
  static RefineChain Of(std::vector<double> t, Mat y, std::vector<std::uint8_t> gamma, Mat u = Mat());
  // K samples at t_k = k·dt (a copy of y).
  static RefineChain Uniform(const Mat& y, double dt, const std::vector<std::uint8_t>& gamma);
};

// The chains of samples (t, y: n × K, gamma as RefineChain's, u: m × K inputs or empty) cut where
// chain_start is 1 (sample 0 always starts one; empty chain_start: one chain). A sample with a
// non-finite entry is missing: it is left out of its chain, which goes on. A chain with no sample
// missing views its columns of y and u (which must outlive it), one with a sample missing holds a copy
// of its samples. Throws std::invalid_argument for sizes that disagree.
std::vector<RefineChain> SplitChains(const std::vector<double>& t, const Mat& y,
                                     const std::vector<std::uint8_t>& chain_start,
                                     const std::vector<std::uint8_t>& gamma, const Mat& u = Mat());
// (The chains would view a temporary.)
std::vector<RefineChain> SplitChains(const std::vector<double>&, Mat&&, const std::vector<std::uint8_t>&,
                                     const std::vector<std::uint8_t>&, const Mat& = Mat()) = delete;
std::vector<RefineChain> SplitChains(const std::vector<double>&, const Mat&, const std::vector<std::uint8_t>&,
                                     const std::vector<std::uint8_t>&, Mat&&) = delete;

// A hybrid automaton (`result.mode` not empty): each chain's jump maps (those of the events of
// `result` inside it, one per event, in order; left empty, so that the refinement checks the event
// count only, when an event has no map) and its initial mode (`result.mode` at its first sample).
// The chains are those of SplitChains at `chain_start` (empty: one chain); nothing is assigned when
// their number differs. Without modes nothing changes.
void AssignChainMaps(const std::vector<std::uint8_t>& chain_start, const IdentifyResult& result,
                     std::vector<RefineChain>* chains);

// The refinement of the chains from the recursive α0, β0 (full vectors). A hybrid automaton: the
// fitted model's jumps must apply the maps a chain assigns to its events (RefineChain::maps; else the
// count and times alone are checked); with several modes, every chain whose initial mode is unknown
// is fit from each candidate mode in turn (the same one for all such chains) and the best fit kept;
// the repaired start and the growing span are not tried for an automaton, nor the mended
// detections for a chain with maps assigned. Per chain the span rule
// (min_jump_interval) applies; chains with fewer than 2n + 2 samples, or whose first sample lies
// outside C ∪ D, are left out. Throws std::invalid_argument for inputs of the wrong size (naming the
// chain; a model with inputs needs every chain's u), times that do not increase, or invalid options;
// numerical outcomes are statuses. A model with inputs is refined without the repaired start (its
// local flows start between samples, where the chains' inputs are not re-timed).
RefineResult Refine(const Model& model, const std::vector<RefineChain>& chains, const Vec& alpha0,
                    const Vec& beta0, const RefineOptions& options = {});

// The same from an identification run on samples (t, y) cut into chains at chain_start (as
// SplitChains): its α̂, β̂ and γ, and for a hybrid automaton its events' maps and modes
// (AssignChainMaps).
RefineResult RefineIdentification(const Model& model, const std::vector<double>& t, const Mat& y,
                                  const std::vector<std::uint8_t>& chain_start,
                                  const IdentifyResult& recursive, const RefineOptions& options = {},
                                  const Mat& u = Mat());

}  // namespace hysid
