// The paper's identifier (Algorithms 1 and 2) over a stream of measured samples ξ(kδt).
//
// Per sample t (from the second on):
//   1. the flow regression of (ξ(t−δt), ξ(t)) on the identified rows (core/model/regression.hpp);
//   2. γ(t) from the jump detector (core/detectors/detector.hpp);
//   3. γ = 0: update α̂ with the flow estimator; γ = 1: update β̂ with the jump estimator on
//      ξ_r(t) = ψ_r(ξ(t−δt))β (eq. 5);
//   4. Algorithm 2: ξ(t−δt) joins Γ when γ(t) = 1, else Λ. (The paper adds ξ(t) to Λ at once and moves
//      ξ(t−δt) to Γ on a jump; deciding ξ(t−δt) one sample later gives the same sets without removing
//      points from a hull. The newest sample is in neither set until the next one arrives.)
//
// Beyond the paper (options, off by default):
//   localize     the jump regression uses the states just before and after the located jump instant
//                s ∈ (t−δt, t] (core/identify/localize.hpp) instead of ξ(t−δt), ξ(t); falls back to the pair
//                when the jump cannot be located.
//   second_pass  Identify() runs the data twice: the second pass re-classifies every sample with the
//                first pass's final α̂ (and its covariance, and the detector's learned state) held
//                fixed, and re-estimates α, β and the sets from scratch on that classification.
//                IdentifyResult says how many samples changed class. Forgetting (EstimatorSettings::
//                forgetting) is the other way to let early mistakes fade.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/detectors/detector.hpp"
#include "core/identify/automaton_event.hpp"
#include "core/estimators/estimator.hpp"
#include "core/model/regression.hpp"
#include "core/sets/sample_set.hpp"

namespace hysid {

namespace detail {
struct IdentifierState;   // core/identify/identifier_state.hpp (internal)
struct IdentifierAccess;  // the same
}  // namespace detail

struct IdentifierSettings {
  // For α and β. gtls and frisch with an empty noise_shape get theirs from WithNoiseShapes (below).
  // The jump regression sees one row per jump (14 in §5), so its frisch window defaults to 0 (the
  // growing window) rather than 200 rows.
  EstimatorSettings flow_estimator;
  EstimatorSettings jump_estimator = [] {
    EstimatorSettings s;
    s.window = 0;
    return s;
  }();
  DetectorSettings detector;
  // Maintain Λ, Γ and their hulls (Algorithm 2), for any number of states (core/sets/sample_set.hpp:
  // 1-D intervals, 2-D angular rings, n ≥ 3 boundary stars; all exact and incremental).
  bool sets = true;
  Vec sigma;  // measurement noise σ per component when known (empty: unknown)
  // Accuracy of the data apart from the random noise: component j may be off by up to
  // data_rtol·|ξ_j| + data_atol (simulated data: the integrator's tolerances; 0 = exact up to
  // rounding). The residual detector adds it to its measurement-noise model; nothing else uses it.
  double data_rtol = 0.0, data_atol = 0.0;
  // Prior for the unknown parameters (empty: zero), for both α and β in model order.
  Vec alpha0, beta0;
  bool localize = false;     // sub-sample jump localisation for the jump regression
  bool second_pass = false;  // Identify(): re-classify with the final α̂ and re-estimate
  // Direct, inlined calls instead of the virtual interfaces: to RLS for α on one identified row, and
  // then also to the paper detector on a constant-Jacobian model or to the residual detector, with
  // compile-time sizes for n = 2 and 1–3 unknowns; to RLS for β on one identified row (same results,
  // bit for bit; see BENCHMARKS.md for the cost per sample). false: always the interfaces (for tests
  // and comparisons).
  bool direct_calls = true;

  // Chooses the estimator for α and β: `kind` for both, except that a flow-only estimator
  // (descriptor flow_only, e.g. integral) leaves β to rls.
  void UseEstimator(EstimatorKind kind);
};

// Noise shapes of the errors-in-variables estimators. For each of flow_estimator and jump_estimator
// whose descriptor needs a noise shape (gtls, frisch) and whose noise_shape is empty, fills it with
// FlowNoiseShape / JumpNoiseShape
// (core/model/noise_shape.hpp) of `sigma` (n entries), δt and `states` (n × K, C averaged over them; for
// φ, ψ affine in ξ, as in every built-in model's identified rows, any one state gives the same C).
//   - sigma all zero (noise-free data): ones instead, i.e. the shape of equal noise on every
//     component (C is used up to scale, so only the ratios between components matter).
//   - a derived C that is zero (no noise reaches that regression): diag(0, …, 0, 1), least squares.
// gtls uses C itself; frisch uses only which diagonal entries are zero (exact columns).
// A noise_shape set by the user is kept. Throws std::invalid_argument for a wrong-sized sigma.
IdentifierSettings WithNoiseShapes(const Model& model, double dt, const IdentifierSettings& settings,
                                   ConstVecRef sigma, const Mat& states);

class Identifier {
 public:
  // Throws std::invalid_argument for δt ≤ 0 or invalid settings (naming the field). gtls / frisch
  // without a noise shape: WithNoiseShapes with settings.sigma (ones when not given) at the model's
  // default initial state. Identify() does better: it estimates σ from the data when not given and
  // averages C over the measured states.
  Identifier(const Model& model, double dt, const IdentifierSettings& settings);
  ~Identifier();
  Identifier(Identifier&&) noexcept;
  Identifier& operator=(Identifier&&) noexcept;

  // Feeds the next measured sample ξ(t). The first sample only initialises (γ = 0, no update).
  Decision Step(ConstVecRef x);
  // The same with γ(t) given (e.g. the true jump labels): the detector is not consulted.
  Decision Step(ConstVecRef x, bool gamma);
  // A model with inputs: each sample with its context (its time and the measured inputs u(t); the
  // values at ctx.u are copied, γ is the model's own). The flow regression takes φ at both samples
  // of a pair with their own u, the jump regression ψ at the pre-jump sample's u, and the detector
  // sees both contexts. Step without a context throws std::invalid_argument for such a model.
  Decision Step(ConstVecRef x, const Context& at);
  Decision Step(ConstVecRef x, bool gamma, const Context& at);
  // Feeds the columns of `samples` (n × K) in order: the same as Step on each, bit for bit, and
  // faster on the direct path (IdentifierSettings::direct_calls), which builds the flow regressions
  // of a block of samples at once (RegressionBuilder::FlowRows). `decisions`, unless null, receives
  // the K decisions. Throws std::invalid_argument when samples.rows() is not the state size, and for
  // a model with inputs (Step with a Context feeds those).
  void Feed(const ConstMatRef& samples, Decision* decisions);
  // Feed with the flow regression rows already built (FlowRows): sample j's row (against the sample
  // before it) at phi + j·|u|, y[j] (the first's unread when nothing was fed before). The same bits
  // as Feed. Models without the direct path ignore the rows.
  void Feed(const ConstMatRef& samples, const double* phi, const double* y, Decision* decisions);
  // Ends the stream: the newest sample joins Λ (the paper puts every ξ(t) in Λ until a jump moves it).
  void Finish();
  // Ends a chain (a gap, a missing sample, the end of a run): the newest sample joins Λ, and the next
  // sample only initialises, so no regression or detector statistic spans the break. Estimators
  // (told by Estimator::Break, as at a jump), sets and the detector's learned state carry on.
  void Restart();
  // δt of the following sample pairs (irregular sampling). Throws std::invalid_argument unless > 0.
  void SetStep(double dt);
  // Starts a second pass over the same stream: α̂ and its covariance are frozen for classification,
  // the estimators and sets restart from their priors, the detector keeps what it has learned.
  void BeginSecondPass();

  Vec alpha_hat() const;  // full α̂: known entries at their known values
  Vec beta_hat() const;
  const Estimator& flow_estimator() const;
  const Estimator& jump_estimator() const;
  const SampleSet& flow_set() const;  // Λ (Ĉ = its hull); empty when settings.sets is false
  const SampleSet& jump_set() const;  // Γ (D̂)
  long samples() const;
  long jumps_detected() const;
  long jumps_localized() const;  // jumps whose regression used the located instant

 private:
  // Its sources and the lockstep driver's (core/identify/lockstep_units.hpp) reach the state through
  // detail::IdentifierAccess.
  friend struct detail::IdentifierAccess;
  std::unique_ptr<detail::IdentifierState> s_;
};

// The flow regression rows of samples y (n × K) for the identifier's direct path: row k ≥ 1 is
// that of the pair (y_{k−1}, y_k) (RegressionBuilder::FlowRows), Φ at phi[k·|u| ..), its value
// y[k]; row 0 is unused. Empty when the model has no one-row flow regression or inputs.
struct FlowRows {
  std::vector<double> phi, y;
  const double* samples = nullptr;  // the data of the matrix they were built from
  Eigen::Index count = 0;           // its K
  double dt = 0.0;
  bool empty() const { return y.empty(); }
};
FlowRows BuildFlowRows(const Model& model, const Mat& y, double dt);

// A whole run: samples y (n × K, column k measured at t_k = kδt, or at times[k]).
struct IdentifyOptions {
  bool trace = false;  // keep per-sample α̂, β̂ (else only γ, statistic, threshold)
  // Keep the detector's statistic and threshold per sample; without them, IdentifyResult's
  // statistic and threshold are empty (sweeps, which count γ against the truth, skip them).
  bool statistics = true;
  // Given labels γ per sample (one per column of y) instead of the detector's decisions, e.g. the
  // true jumps, to study the estimators alone. Empty: the detector decides.
  std::vector<std::uint8_t> labels{};
  // Irregular sampling: the time of each sample (one per column of y); each pair uses its own step.
  // Empty: t_k = kδt.
  std::vector<double> times{};
  // 1 where a chain starts (a new run, a gap): Identifier::Restart before that sample. Empty: one
  // chain. With either of these two, or a non-finite column in y, samples are fed one by one; a
  // column with a non-finite entry is a missing sample: skipped (γ = 0, statistic 0), and the chain
  // goes on, the next pair's step spanning it (from times, else the steps of δt counted).
  std::vector<std::uint8_t> chain_start{};
  // The measured inputs u of a model with inputs (m × K, column k at sample k, finite), required for
  // such a model; each sample is then fed with its context (t_k from times, else kδt; u column k).
  Mat inputs{};
  // The paper detector: check at the end that its bound can hold for the whole flow (states of very
  // different scales break it: CheckPaperBound, core/detectors/paper.hpp); when it cannot, the jump
  // estimate is ill-conditioned with the reason. Sweeps, which count every detection against the
  // true jumps, turn it off: their tables keep the detector's outcome as it is.
  bool check_paper_bound = true;
  // Check the final α̂ against its data (CheckFlowResiduals, core/identify/self_check.hpp): flow
  // residuals far above the noise, or jumps in data where the detector found none, make the flow
  // status kInconsistent with the reason. Applies when the detector decides (no labels), to the
  // paper's class (not a hybrid automaton).
  bool check_residuals = true;
  // A hybrid automaton (IsAutomaton: several modes or explicit jump maps). assign_events: Identify
  // detects the events, assigns each to a map, infers the initial mode and runs the pass with the
  // modes and maps found (core/identify/events.hpp, IdentifyAutomaton). Off: one pass with `modes`
  // (each sample's mode) and `maps` (the map of a jump into each sample) as given, 0 when empty.
  bool assign_events = true;
  std::vector<int> modes{}, maps{};
  int initial_mode = -1;  // the mode at the first sample when known (−1: inferred)
  KinkSettings kinks{};
  // Raised (a signal handler, Python's Ctrl-C): the pass ends within kStopPollSamples samples (a
  // sixteenth of that with hulls of n ≥ 3 states, whose insertions cost more), and the final
  // vertices and volumes of n ≥ 3 hulls look at it every 4096 boundary facets and every 16 exact
  // vertex tests (SampleSet::vertices(stop)); the result says IdentifyResult::stopped: both statuses
  // kNotExcited with reason "stopped", no hulls, no second pass, no safe start. Null: never.
  const std::atomic<bool>* stop = nullptr;
  static constexpr long kStopPollSamples = 4096;
  // The flow regression rows of this call's samples (BuildFlowRows of the same model, y and δt),
  // built once and shared by calls that differ only in settings (the sweep's detector settings on
  // one trial's samples); used by the block path (no times, chains, inputs, labels or trace). Null
  // or empty: built in each pass; not used for a hybrid automaton with assign_events. Throws
  // std::invalid_argument when they were built from another matrix, sample count or δt.
  const FlowRows* flow_rows = nullptr;
};

struct IdentifyResult {
  Vec alpha_hat, beta_hat;          // final, full vectors
  // Per sample (gamma[0] = 0): 1 where the jump regression took the pair; a hybrid automaton's
  // switches (events without a jump) are 1 too (IdentifyResult::events says which is which).
  std::vector<std::uint8_t> gamma;
  std::vector<double> statistic;    // detector statistic per sample (paper: D_δt ξ)
  std::vector<double> threshold;    // its threshold (paper: τ̂)
  Mat alpha_trace, beta_trace;      // |α| × K and |β| × K when options.trace
  long jumps_detected = 0;
  EstimatorStatus flow_status = EstimatorStatus::kNotExcited;
  EstimatorStatus jump_status = EstimatorStatus::kNotExcited;
  std::string flow_reason, jump_reason;  // why a status is not ok (Estimator::reason)
  // When the α estimator ends not ok and is not rls: the same run with rls for α (its own
  // detections, sets and statuses), from which a refinement starts (RefinementStart), and why.
  std::shared_ptr<const IdentifyResult> safe_start;
  std::string safe_start_reason;
  Mat flow_hull, jump_hull;  // n × h hull vertices of Λ and Γ (when settings.sets)
  // Why the hulls are empty although settings.sets: more states than the limit kMaxHullDimension
  // (core/io/limits.hpp; exact hulls cost exponentially in the dimension). "" otherwise.
  std::string sets_skipped;
  double flow_hull_volume = 0.0, jump_hull_volume = 0.0;
  long jumps_localized = 0;  // settings.localize: jumps regressed at the located instant
  // settings.second_pass: the first pass's outcome and what the second changed. gamma, estimates
  // and traces above are the second pass's.
  bool second_pass = false;
  std::vector<std::uint8_t> first_pass_gamma;
  Vec first_pass_alpha_hat, first_pass_beta_hat;
  long reclassified_to_jump = 0;  // flow in the first pass, jump in the second
  long reclassified_to_flow = 0;  // jump in the first pass, flow in the second
  // gtls / frisch with a derived noise shape: the σ it was derived from, and whether that σ was
  // estimated from the data (EstimateNoiseSigma) because settings.sigma was empty. Empty otherwise.
  Vec noise_sigma;
  bool noise_sigma_estimated = false;
  Mat flow_noise_shape, jump_noise_shape;  // the shapes the estimators used (empty for rls)
  // Estimators that report a solution box (frisch): the final boxes of the unknowns, u × 2 (lower,
  // upper); empty otherwise.
  Mat flow_box, jump_box;
  // IdentifyOptions::chain_start or non-finite columns: samples skipped (non-finite), chains fed.
  long skipped_samples = 0;
  long chains = 1;
  // A hybrid automaton (IdentifyOptions::assign_events): the events in time order with their maps,
  // the mode of each sample, the initial mode (given, or inferred: the candidate whose flow
  // regression over the whole run has the least residual sum of squares, one per mode in
  // initial_mode_rss), and why an assignment is not to be trusted ("" when every event found an
  // armed map). Empty for the paper's class.
  std::vector<AutomatonEvent> events;
  std::vector<int> mode;
  int initial_mode = 0;
  bool initial_mode_inferred = false;
  std::vector<double> initial_mode_rss;
  std::string events_reason;
  // IdentifyOptions::stop was raised: the pass ended early; the estimates are those of the samples
  // seen (partial) and not ok.
  bool stopped = false;
};

// gtls / frisch without a noise shape: σ = settings.sigma when given, else EstimateNoiseSigma(y) (MAD
// of second differences, core/model/noise_shape.hpp); C from WithNoiseShapes over up to 256 evenly spaced
// columns of y.
IdentifyResult Identify(const Model& model, const Mat& y, double dt, const IdentifierSettings& settings,
                        const IdentifyOptions& options = {});

// The recursive result a refinement starts from: recursive.safe_start when there is one (the α
// estimator was not ok), else recursive itself.
const IdentifyResult& RefinementStart(const IdentifyResult& recursive);

}  // namespace hysid
