// One identification, below both front-ends: a typed request (the model, the samples and every setting
// `hysid identify` and `hysid.identify` accept) in, one outcome (the recursive result, the refinement,
// the bound at the truth, the partial outputs) out. The command line and the Python module only
// translate their inputs into the request and the outcome into their output; OutcomeJson
// (outcome_json.hpp) describes the outcome once. Refusals name the option as `spelling` spells it.
#pragma once

#include <atomic>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/identify/identifier.hpp"
#include "core/io/sample_data.hpp"
#include "core/model/model.hpp"
#include "experiments/request/checks.hpp"
#include "experiments/sweep/progress.hpp"
#include "sim/events/fitted_events.hpp"
#include "sim/events/fitted_outputs.hpp"
#include "sim/refine/refine.hpp"
#include "sim/sensitivity/crlb.hpp"

namespace hysid {

// The truth the estimates are compared with: the simulation's x0 and σ (the command line: from the
// sidecar of data written by `hysid simulate`; Python: truth=); empty: none.
struct Truth {
  Vec x0, sigma;
};

struct IdentifyRequest {
  explicit IdentifyRequest(Model m) : model(std::move(m)) {}
  Model model;      // with its true values (--param) and bounds (ApplyBounds) set
  SampleData data;  // the measured rows (MeasuredIndices order), inputs u and the ground truth j, map, q
  std::string estimator = "rls";
  std::string detector = "residual";
  // The detector's and the estimators' options given, by keyword ("r", "jump_forgetting"), as text.
  std::map<std::string, std::string> plugin_options;
  Mat flow_noise_shape, jump_noise_shape;  // gtls/frisch: the noise shapes C (empty: from σ and δt)
  bool localize = false;
  bool second_pass = false;
  bool keep_outliers = false;  // else LeaveOutOutliers (core/io/sample_data.hpp) before the recursive pass
  bool sets = true;        // compute the hulls C^ and D^
  bool trace = false;      // keep the per-sample estimates (α̂, β̂ after every sample)
  bool statistics = true;  // keep the detector's per-sample statistic and threshold
  std::vector<double> sigma;  // known measurement noise: one, or one per measured state; empty: estimated
  double data_rtol = 0.0, data_atol = 0.0;
  std::string data_accuracy_source = "none given";  // where data_rtol and data_atol came from
  std::string refine = "ml";                        // "ml" or "none"
  std::optional<std::string> x0_known;              // KnownX0's text; nullopt: not given
  std::vector<double> x0;                           // with x0_known: the initial state (default: the model's)
  Truth truth;
  // After the recursive report is described: drop the per-sample arrays only it reads (the detector's
  // statistic and the estimate traces), so that the refinement's peak does not hold them.
  bool release_per_sample = false;
  Spelling spelling = Spelling::kKeyword;  // how refusals name the options
  const std::atomic<bool>* stop = nullptr;  // ends the reconstruction, the recursive pass and the refinement
  StageProgress* progress = nullptr;
};

// The states the data holds: the measured ones (indices; every state when all are measured), the
// others reconstructed as a start (core/identify/reconstruct.hpp), and how.
struct PartialOutputs {
  std::vector<int> measured;
  std::vector<int> reconstructed;
  std::string reconstruction;  // how (windows, segments, jump detection); "" when all are measured
};

// The refinement (refine "ml") or the recursive estimate as the result (refine "none"), and what is
// computed from it.
struct RefineStep {
  RefineResult result;
  RefineOptions options;
  std::vector<int> known;  // x0_known
  Crlb bound;              // at the truth (not ok without one)
  HybridParameters truth;
  FittedEvents fitted;     // a hybrid automaton refined: its events' times from the fit
  FittedOutputs outputs;   // the fitted and the recursive model run over the whole record
  // Samples left out by the fit (RefitWithoutOutliers in request.cpp): `sds` their residual off the
  // first fit in robust sd, `row` the measured state's index in SampleData::state_columns.
  std::vector<OutlierSample> fit_outliers;
  // The samples of the span fitted: those used and those the fit left out inside it.
  long span() const { return result.samples_used + static_cast<long>(fit_outliers.size()); }
  // Notes, not refusals: an estimate kUnitsFactor times or more larger or smaller in magnitude than its
  // start value (the model's value) says "check the units"; a recursive estimate outside its bounds.
  std::vector<std::string> notes;
};
inline constexpr double kUnitsFactor = 100.0;
// RefitWithoutOutliers: a run of at most kFitOutlierRun samples beyond kOutlierSds robust sd off the
// fit, the samples beside it within kFitOutlierNeighbour robust sd or kFitOutlierFraction of the run's
// least; at most kFitOutlierShare of the samples.
inline constexpr int kFitOutlierRun = 2;
inline constexpr double kFitOutlierNeighbour = 3.0;
inline constexpr double kFitOutlierFraction = 0.1;
inline constexpr double kFitOutlierShare = 0.01;

// The samples that stand alone off a fit (RefitWithoutOutliers): per measured state (`measured`: the
// model's state indices; data.y holds those rows, or every state's), |y − fit.matched| in robust sd of
// that state's residuals over the samples where it is finite; a sample beyond kOutlierSds in some state,
// in a run of at most kFitOutlierRun such samples inside its chain, the samples beside the run within
// kFitOutlierNeighbour robust sd or kFitOutlierFraction of the run's least; none when they are more than
// kFitOutlierShare of the samples. In order, with their columns of data.y in `at`; `sds` the residual,
// `row` the measured state's index among `measured`.
std::vector<OutlierSample> FitOutliers(const SampleData& data, const std::vector<int>& measured,
                                       const FittedOutputs& fit, std::vector<Eigen::Index>* at);

struct IdentifyOutcome {
  explicit IdentifyOutcome(Model m) : model(std::move(m)) {}
  Model model;  // the model identified
  IdentifierSettings settings;
  SampleData data;         // the samples as identified: n × K when states were reconstructed
  IdentifyOptions options;  // the labels and inputs the pass used
  IdentifyResult recursive;
  PartialOutputs partial;
  Vec sigma;                // per measured state, or empty
  std::vector<int> x0_known;  // the components of ξ0 held at x0 (checked), or empty
  Vec x0;                     // their values, the whole ξ0 (checked), when x0_known is not empty
  std::vector<double> kinks;  // unmeasured states reconstructed: the kink statistic, the detector's in the report
  std::string refine;       // the request's
  nlohmann::json recursive_report;  // RecursiveJson (outcome_json.hpp), set by RunRefinement
  RefineStep refinement;            // set by RunRefinement
  // refine "ml": the refinement's status is ok; "none": both recursive estimators are ok.
  bool ok() const;
};

// The identifier's settings from the request (plugins by name, their options, noise shapes, data
// accuracy, σ when every state is measured); throws std::invalid_argument naming the option.
IdentifierSettings CheckedSettings(const IdentifyRequest& request);
// Every check of the request that needs no samples (CheckedSettings, bounds without refinement, σ per
// measured state and its range), and those that need them (x0_known and x0 against the samples).
void CheckRequest(const IdentifyRequest& request);
void CheckRequestData(const IdentifyRequest& request);
// A noise shape given as (p+1)² values, row-major: finite and square; errors name the option
// ("flow_noise_shape").
Mat NoiseShapeOf(const std::vector<double>& values, const std::string& option, Spelling spelling);

// Data files as the request's samples: the measured states (the columns named after them, else the
// default rule of core/io/sample_data.hpp, or `columns`: "t=NAME", the states in order, "run=NAME"),
// the model's inputs by name, chains broken at steps longer than `max_gap` (0: 5 × the median step).
// A message about the column choice names `columns` as `spelling` spells it.
SampleData ReadSampleFiles(const std::vector<std::string>& paths, const Model& model,
                           const std::vector<std::string>& columns, double max_gap, Spelling spelling);

// The whole identification: RunRecursivePass, then RunRefinement. A C++ caller (e.g. comparing model
// files on one record) builds the request from a model (LoadModelFile) and ReadSampleFiles; the
// outcome's refinement.result holds the fit (names: the parameters fitted, final_cost: ½ Σ (r/σ)²,
// samples_used, sigma, status) and refinement.outputs the fitted model over the record (its residuals:
// FitColumns, outcome_json.hpp).
IdentifyOutcome RunIdentification(IdentifyRequest request);
// The checks, the reconstruction of unmeasured states and the recursive pass; `request.data` is
// moved into the outcome.
IdentifyOutcome RunRecursivePass(IdentifyRequest& request);
// The recursive pass again on the outcome's samples, with `model` (a chosen model of a selection).
void RunRecursivePassAgain(const IdentifyRequest& request, const Model& model, IdentifyOutcome* outcome);
// The recursive report described (when not yet), the refinement (or the recursive estimate kept), the
// bound at the truth, the fitted model over the record and the notes.
void RunRefinement(const IdentifyRequest& request, IdentifyOutcome* outcome);

// The notes on the estimate `e` against the model's values (unknown α, β and guard parameters with a
// start value other than 0).
std::vector<std::string> UnitNotes(const Model& model, const HybridParameters& e);

}  // namespace hysid
