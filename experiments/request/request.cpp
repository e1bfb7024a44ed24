#include "experiments/request/request.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <tuple>
#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/identify/reconstruct.hpp"
#include "core/model/automaton.hpp"
#include "experiments/request/outcome_json.hpp"
#include "sim/input_signal.hpp"
#include "sim/refine/solver_progress.hpp"
#include "sim/sensitivity/sensitivity.hpp"

namespace hysid {
namespace {

// The states the measured ones cannot give (ReconstructionPlan::error): each chain simulated from the
// model's own values (a model file's start values), from its first sample's measured states and the
// model's default for the others; the measured rows are the data's. A start only: the refinement
// fits every state from there.
Mat SimulatedStates(const Model& model, const std::vector<int>& measured, const SampleData& data) {
  const int n = model.state_size();
  const Eigen::Index K = data.y.cols();
  const Vec fallback = DefaultState(model);
  Mat x = fallback.replicate(1, K);
  for (std::size_t r = 0; r < measured.size(); ++r) x.row(measured[r]) = data.y.row(Eigen::Index(r));
  SensitivityOptions o;
  o.sensitivities = false;
  o.sim.rtol = o.sim.atol = 1e-8;
  for (Eigen::Index a = 0; a < K;) {
    Eigen::Index b = a + 1;
    while (b < K && (data.chain_start.empty() || !data.chain_start[std::size_t(b)])) ++b;
    std::vector<double> times;
    for (Eigen::Index k = a; k < b; ++k) times.push_back(data.t[std::size_t(k)] - data.t[std::size_t(a)]);
    InputSignal inputs;
    if (data.u.rows() > 0) {
      inputs.times = times;
      inputs.values = data.u.middleCols(a, b - a);
    }
    SensitivityTrajectory run;
    try {
      if (times.size() >= 2) {
        run = SimulateSensitivities(model, HybridParameters::Of(model, x.col(a)), Unknowns{{}, {}, {}, false}, times,
                                    o, inputs.empty() ? nullptr : &inputs);
      }
    } catch (const std::invalid_argument&) {  // the first sample outside C and D: the default stands
    }
    for (Eigen::Index k = 0; k < b - a; ++k) {
      const long at = std::min<long>(k, run.trajectory.size() - 1);
      if (at < 0) break;
      for (int j = 0; j < n; ++j) {
        if (std::find(measured.begin(), measured.end(), j) == measured.end()) x(j, a + k) = run.trajectory.x(j, at);
      }
    }
    a = b;
  }
  return x;
}

// Only some states measured: the others reconstructed from the measured ones on the flow segments
// between the kinks detected in them (core/identify/reconstruct.hpp), data.y replaced by the n × K
// reconstruction and the detected jumps given to the identifier as labels. Returns what was done.
PartialOutputs Reconstruct(const Model& model, const std::vector<int>& measured, const Vec& sigma,
                           SampleData& data, IdentifyOptions& options, std::vector<double>* statistic) {
  PartialOutputs partial;
  partial.measured = measured;
  if (static_cast<int>(measured.size()) == model.state_size()) return partial;
  const ReconstructionPlan plan = PlanReconstruction(model, measured);
  if (!plan.ok()) {
    for (int i = 0; i < model.state_size(); ++i) {
      if (std::find(measured.begin(), measured.end(), i) == measured.end()) partial.reconstructed.push_back(i);
    }
    data.y = SimulatedStates(model, measured, data);
    partial.reconstruction = fmt::format(
        "simulated from the model's own values (a start only: {}; the refinement fits them with the model)",
        plan.error);
    return partial;
  }
  ReconstructOptions ro;
  ro.stop = options.stop;
  const Reconstruction r = ReconstructStates(plan, data.t, data.y, data.chain_start, sigma, ro);
  partial.reconstructed = plan.reconstructed;
  const auto& names = model.spec().state_names;
  std::vector<std::string> from;
  for (const int i : plan.reconstructed) {
    from.push_back(fmt::format("{} from d{}/dt", names[static_cast<std::size_t>(i)],
                               names[static_cast<std::size_t>(plan.source[static_cast<std::size_t>(i)])]));
  }
  partial.reconstruction = fmt::format(
      "{} (a start only: Savitzky–Golay slopes of degree 2, windows of {}–{} samples, on {} flow segments "
      "between {} jumps detected as kinks in the measured states above {:g} noise sd, sigma {})",
      fmt::join(from, ", "), r.min_window, r.max_window, r.segments,
      std::count(r.gamma.begin(), r.gamma.end(), 1), ro.kink_threshold, fmt::format("{:.4g}", fmt::join(r.sigma, ", ")));
  data.y = r.x;
  options.labels = r.gamma;
  *statistic = r.statistic;
  return partial;
}

// Identify on the data: the times and chain starts when the data are not uniform (each pair with its
// own step, chains restarted at runs, gaps and missing rows) and the model's inputs (m × K, read by
// name) lent to it, moved into `options` and back (no second copy of a per-sample array).
IdentifyResult IdentifyData(const Model& model, const IdentifierSettings& settings, SampleData& data,
                            IdentifyOptions& options) {
  if (!data.uniform) {
    options.times = std::move(data.t);
    options.chain_start = std::move(data.chain_start);
  }
  options.inputs = std::move(data.u);
  IdentifyResult result = Identify(model, data.y, data.dt, settings, options);
  if (!data.uniform) {
    data.t = std::move(options.times);
    data.chain_start = std::move(options.chain_start);
  }
  data.u = std::move(options.inputs);
  return result;
}

// What only the recursive part of the report reads (printed, --trace and --json's `report` built by
// then): the detector's statistic and threshold and the estimates' traces. Freed, so that the
// refinement's peak does not hold them (each sample's run and line stay: the fit names the samples
// it leaves out).
void ReleaseReported(IdentifyResult& result) {
  std::vector<double>().swap(result.statistic);
  std::vector<double>().swap(result.threshold);
  result.alpha_trace = Mat();
  result.beta_trace = Mat();
}

// The context of the data's first sample: its time and inputs (C and D of a model with inputs read u).
Context FirstSample(const SampleData& data) {
  return {.t = data.t.front(), .u = data.u.rows() > 0 ? data.u.col(0).data() : nullptr};
}

// The CRLB at the truth when the data carry it (sidecar x0 and σ > 0, same grid) over at least two
// samples (a refinement that fitted fewer has no span to bound), else not ok; with the data's inputs
// (their times from the first sample's) for a model with inputs.
Crlb TruthBound(const Model& model, const Truth& truth, long samples, const SampleData& data,
                const std::vector<int>& measured, const std::vector<int>& known) {
  const double dt = data.dt;
  if (truth.x0.size() == 0 || truth.sigma.size() == 0 || !(truth.sigma(measured).array() > 0.0).all() ||
      samples < 2) {
    Crlb none;
    none.status = CrlbStatus::kSimulationFailed;
    none.message = samples < 2 ? "fewer than 2 samples fitted" : "no truth";
    return none;
  }
  const SampleGrid grid{.t_end = static_cast<double>(samples - 1) * dt, .dt = dt};
  InputSignal inputs;
  if (data.u.rows() > 0) {
    for (double t : data.t) inputs.times.push_back(t - data.t.front());
    inputs.values = data.u;
  }
  const bool all = static_cast<int>(measured.size()) == model.state_size();
  const Unknowns unknowns = Unknowns::Of(model);
  // The known components of ξ0 held, as the refinement holds them.
  return HoldKnownX0(
      ComputeCrlb(model, truth.x0, grid, all ? truth.sigma : Vec(truth.sigma(measured)), unknowns, {},
                  all ? std::vector<int>{} : measured, inputs.empty() ? nullptr : &inputs),
      unknowns, known, model.state_size());
}

// A chain that starts after a gap in the run of the chain before it (not at a run's start). Without
// the per-sample runs, one run means every chain after the first. A model
// with inputs is not run through a gap: the data do not hold its input there (linear interpolation
// across the gap would invent it), so each chain keeps its own initial state.
void MarkGaps(const SampleData& data, std::vector<RefineChain>* chains) {
  if (data.u.rows() > 0) return;
  std::vector<std::size_t> first;
  for (std::size_t k = 0; k < data.chain_start.size(); ++k) {
    if (k == 0 || data.chain_start[k]) first.push_back(k);
  }
  if (first.size() != chains->size()) return;
  const bool runs = data.run.size() == data.chain_start.size();
  if (!runs && data.run_names.size() > 1) return;
  for (std::size_t c = 1; c < first.size(); ++c) {
    (*chains)[c].after_gap = !runs || data.run[first[c]] == data.run[first[c - 1]];
  }
}

// From RefinementStart(recursive): the recursive result itself, or its rls re-run when the α
// estimator was not ok.
RefineResult RefineOnChains(const Model& model, const SampleData& data, const IdentifyResult& given,
                           const RefineOptions& options) {
  const IdentifyResult& recursive = RefinementStart(given);
  std::vector<RefineChain> chains = SplitChains(data.t, data.y, data.chain_start, recursive.gamma, data.u);
  AssignChainMaps(data.chain_start, given, &chains);
  MarkGaps(data, &chains);
  return Refine(model, chains, recursive.alpha_hat, recursive.beta_hat, options);
}

// Calls f(parameter, estimate) for each unknown α, β and guard parameter of the estimate `e`.
void ForEachUnknown(const Model& model, const HybridParameters& e,
                    const std::function<void(const Parameter&, double)>& f) {
  const ModelSpec& spec = model.spec();
  for (const auto& [params, values] : {std::pair{&spec.alpha, &e.alpha}, std::pair{&spec.beta, &e.beta},
                                       std::pair{&spec.guard_params, &e.gamma}}) {
    for (std::size_t i = 0; i < params->size() && static_cast<Eigen::Index>(i) < values->size(); ++i) {
      if (!(*params)[i].known) f((*params)[i], (*values)[static_cast<Eigen::Index>(i)]);
    }
  }
}

// The notes on the unknown α, β and guard parameters of `e` outside the model's bounds (a model file's
// `bounds`, param_bound): only the refinement applies bounds, so such an estimate is the recursive one.
std::vector<std::string> BoundNotes(const Model& model, const HybridParameters& e) {
  std::vector<std::string> notes;
  ForEachUnknown(model, e, [&](const Parameter& p, double estimate) {
    if (!(estimate < p.lower || estimate > p.upper)) return;
    notes.push_back(fmt::format("{} = {:.6g} lies outside its bounds [{:g}, {:g}]: this is the recursive "
                                "estimate, which applies no bounds (only the refinement does)",
                                p.name, estimate, p.lower, p.upper));
  });
  return notes;
}

// A hybrid automaton refined: each event's time from the fitted model (its guard crossing, sim/events).
FittedEvents FittedEventsOf(const Model& model, const SampleData& data, const IdentifyResult& r,
                            const RefineResult& refined) {
  if (!IsAutomaton(model.spec())) return {};
  return FitEventTimes(model, data.t, data.y, data.chain_start, data.u, r, refined);
}

// The measured states' indices among the model's states.
std::vector<int> MeasuredOf(const IdentifyOutcome& o) {
  return o.partial.measured.empty() ? MeasuredIndices(o.model) : o.partial.measured;
}

// A fit refused as residual-rms, or one ok on a span it cut short, with a few samples that stand off
// it alone (FitOutliers): fitted again from the recursive estimate without them, and that fit kept
// when its residuals pass every test (status ok) and, if the first was ok, it fits more samples; the
// samples are then listed in fit_outliers. Anything else keeps the first fit. True when s.outputs
// holds the fitted model's run for the fit kept.
bool RefitWithoutOutliers(const IdentifyOutcome& o, const std::vector<int>& measured, RefineStep& s) {
  RefineResult& r = s.result;
  const bool cut = r.ok() && r.samples_used < o.data.y.cols();
  if (!(r.status == RefineStatus::kResidualRms && r.reported) && !cut) return false;
  const SampleData& data = o.data;
  s.outputs = RunFittedModel(o.model, data.t, data.y, data.chain_start, data.u, o.recursive, r);
  std::vector<Eigen::Index> at;
  std::vector<OutlierSample> found = FitOutliers(data, measured, s.outputs, &at);
  if (found.empty()) return true;
  SampleData without = data;
  for (const Eigen::Index k : at) without.y.col(k).setConstant(std::numeric_limits<double>::quiet_NaN());
  RefineResult again = RefineOnChains(o.model, without, o.recursive, s.options);
  if (!again.ok() || (r.ok() && again.samples_used <= r.samples_used)) return true;
  r = std::move(again);
  s.fit_outliers = std::move(found);
  return false;
}

// The refinement (refine "ml") or the recursive estimate (none), and the bound at the truth.
RefineStep RunRefineStep(const IdentifyRequest& request, const IdentifyOutcome& o) {
  const Model& model = o.model;
  const SampleData& data = o.data;
  const IdentifyResult& recursive = o.recursive;
  const PartialOutputs& partial = o.partial;
  StageProgress* progress = request.progress;
  const bool ml = request.refine == "ml";
  RefineStep s;
  s.options.stop = request.stop;
  s.known = o.x0_known;
  RefineResult& r = s.result;
  s.options.sigma = o.sigma;
  if (!partial.reconstructed.empty()) s.options.measured = partial.measured;
  s.options.x0_known = o.x0_known;
  s.options.x0 = o.x0;
  bool have_outputs = false;  // s.outputs already run for the fit kept
  if (ml) {
    if (progress != nullptr) progress->Stage("refinement");
    const ScopedSolverProgress watch([progress](int fit, int iteration, double cost) {
      if (progress != nullptr) progress->Iteration(fit, iteration, cost);
    });
    r = RefineOnChains(model, data, recursive, s.options);
    have_outputs = !request.keep_outliers && RefitWithoutOutliers(o, MeasuredOf(o), s);
  } else {
    r.unknowns = Unknowns::Of(model);
    r.names = r.unknowns.Names(model);
    r.start = r.estimate =
        HybridParameters{recursive.alpha_hat, recursive.beta_hat, data.y.col(0), model.gamma()};
  }
  const long used = ml ? s.span() : data.y.cols();
  s.bound = TruthBound(model, request.truth, used, data, MeasuredOf(o), s.known);
  s.truth = HybridParameters::Of(model, request.truth.x0);
  if (progress != nullptr) progress->Stage("the fitted model over the record");
  if (ml && IsAutomaton(model.spec())) s.fitted = FittedEventsOf(model, data, recursive, r);
  if (!have_outputs)
    s.outputs = RunFittedModel(model, data.t, data.y, data.chain_start, data.u, recursive, r);
  if (progress != nullptr) progress->Clear();
  s.notes = UnitNotes(model, r.estimate);
  for (std::string& note : BoundNotes(model, r.estimate)) s.notes.push_back(std::move(note));
  return s;
}

}  // namespace

// Robust sd: 1.4826 × the median |residual| (past a span the fit cut, the residuals off its
// prediction). A model that misses an event or a kink leaves residuals that rise and fall over several
// samples, which the run length and the samples beside it refuse; more than kFitOutlierShare of the
// samples is a model error, not a few bad samples.
std::vector<OutlierSample> FitOutliers(const SampleData& data, const std::vector<int>& measured,
                                       const FittedOutputs& fit, std::vector<Eigen::Index>* at) {
  const Eigen::Index K = data.y.cols();
  const bool full = data.y.rows() == fit.matched.rows();
  const auto m = static_cast<Eigen::Index>(measured.size());
  Mat z = Mat::Constant(m, K, std::numeric_limits<double>::quiet_NaN());  // |residual| in robust sd
  for (Eigen::Index r = 0; r < m; ++r) {
    const Eigen::Index row = full ? measured[std::size_t(r)] : r;
    std::vector<double> a;
    for (Eigen::Index k = 0; k < K; ++k) {
      const double e = data.y(row, k) - fit.matched(measured[std::size_t(r)], k);
      if (std::isfinite(e)) {
        z(r, k) = std::abs(e);
        a.push_back(std::abs(e));
      }
    }
    if (a.size() < 12) return {};
    std::nth_element(a.begin(), a.begin() + std::ptrdiff_t(a.size() / 2), a.end());
    const double sd = 1.4826 * a[a.size() / 2];
    if (!(sd > 0.0)) return {};
    z.row(r) /= sd;
  }
  auto worst = [&](Eigen::Index k) { return z.col(k).maxCoeff(); };  // NaN-free columns only
  auto scored = [&](Eigen::Index k) { return z.col(k).allFinite(); };
  auto chain_starts = [&](Eigen::Index k) {
    return k == 0 || (!data.chain_start.empty() && data.chain_start[std::size_t(k)]);
  };
  std::vector<OutlierSample> out;
  for (Eigen::Index k = 0; k < K;) {
    if (!scored(k) || !(worst(k) > kOutlierSds)) {
      ++k;
      continue;
    }
    Eigen::Index end = k + 1;  // the run [k, end) within the chain
    while (end < K && !chain_starts(end) && scored(end) && worst(end) > kOutlierSds) ++end;
    const bool short_run = end - k <= kFitOutlierRun;
    double least = worst(k);
    for (Eigen::Index i = k + 1; i < end; ++i) least = std::min(least, worst(i));
    const double beside = std::max(kFitOutlierNeighbour, kFitOutlierFraction * least);
    const bool clean_before = chain_starts(k) || (scored(k - 1) && worst(k - 1) <= beside);
    const bool clean_after = end == K || chain_starts(end) || (scored(end) && worst(end) <= beside);
    if (short_run && clean_before && clean_after) {
      for (Eigen::Index i = k; i < end; ++i) {
        Eigen::Index r = 0;
        z.col(i).maxCoeff(&r);
        const Eigen::Index row = full ? measured[std::size_t(r)] : r;
        at->push_back(i);
        out.push_back({.run = data.run.empty() ? 0 : data.run[std::size_t(i)],
                       .line = data.line.empty() ? 0 : data.line[std::size_t(i)],
                       .t = data.t[std::size_t(i)],
                       .row = static_cast<int>(r),
                       .value = data.y(row, i),
                       .sds = z(r, i)});
      }
    }
    k = end;
  }
  if (static_cast<double>(out.size()) > kFitOutlierShare * static_cast<double>(K)) {
    out.clear();
    at->clear();
  }
  return out;
}

Mat NoiseShapeOf(const std::vector<double>& v, const std::string& option, Spelling spelling) {
  if (v.empty()) return Mat();
  const std::string name = Spelled(option, spelling);
  CheckFinite(name, v);
  const auto m = static_cast<Eigen::Index>(std::lround(std::sqrt(double(v.size()))));
  if (m * m != static_cast<Eigen::Index>(v.size())) {
    throw std::invalid_argument(
        fmt::format("{} has {} values: give a square matrix (parameters + 1)^2, row-major", name, v.size()));
  }
  return Mat(Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      v.data(), m, m));
}

namespace {

// σ per measured state (empty when not given), checked.
Vec MeasuredSigma(const IdentifyRequest& request) {
  if (request.sigma.empty()) return Vec();
  return CheckedNoiseSigma(request.sigma, static_cast<int>(MeasuredIndices(request.model).size()),
                           request.spelling);
}

}  // namespace

IdentifierSettings CheckedSettings(const IdentifyRequest& request) {
  const Model& model = request.model;
  const Spelling spelling = request.spelling;
  IdentifierSettings settings;
  SetPluginKinds(request.estimator, request.detector, spelling, &settings);
  ApplyPluginOptions(request.plugin_options, spelling, &settings);
  settings.flow_estimator.noise_shape = request.flow_noise_shape;
  settings.jump_estimator.noise_shape = request.jump_noise_shape;
  CheckNoiseShapesUsed(settings, request.flow_noise_shape.size() > 0, request.jump_noise_shape.size() > 0,
                       spelling);
  if (request.localize && IsAutomaton(model.spec())) {
    throw std::invalid_argument(
        fmt::format("{}: model '{}' is a hybrid automaton (modes or jump maps); the jump localiser fits one flow "
                    "and one jump map, so it is not available for it",
                    Spelled("localize", spelling), model.name()));
  }
  settings.localize = request.localize;
  settings.second_pass = request.second_pass;
  settings.sets = request.sets;
  CheckDataAccuracy(request.data_rtol, request.data_atol, spelling);
  settings.data_rtol = request.data_rtol;
  settings.data_atol = request.data_atol;
  if (static_cast<int>(MeasuredIndices(model).size()) == model.state_size())
    settings.sigma = MeasuredSigma(request);
  try {  // settings errors (noise shape sizes, ...) before the data is read
    Identifier check(model, 1.0, settings);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(fmt::format("{}/{}/{}: {}", Spelled("estimator", spelling),
                                            Spelled("detector", spelling), Spelled("*_noise_shape", spelling),
                                            e.what()));
  }
  return settings;
}

namespace {

// Unmeasured states reconstructed: the detector's statistic and threshold are the kinks'.
void UseKinks(IdentifyOutcome* o) {
  if (o->partial.reconstructed.empty() || !o->options.statistics) return;
  o->recursive.statistic = o->kinks;
  o->recursive.threshold.assign(o->kinks.size(), ReconstructOptions{}.kink_threshold);
}

}  // namespace

void CheckRequest(const IdentifyRequest& request) {
  if (const std::string problem = RefineChoiceProblem(request.refine); !problem.empty())
    throw std::invalid_argument(fmt::format("{}: {}", Spelled("refine", request.spelling), problem));
  CheckedSettings(request);
  MeasuredSigma(request);
}

namespace {

// x0_known and x0 checked against `model` and the samples: the components held and ξ0 (its size and
// C ∪ D), or nothing when x0_known is not given.
std::pair<std::vector<int>, Vec> CheckedKnownX0(const IdentifyRequest& request, const Model& model,
                                                const SampleData& data) {
  const Spelling spelling = request.spelling;
  std::vector<int> known = KnownX0(request.x0_known, model, spelling);
  const std::string x0 = Spelled("x0", spelling), x0_known = Spelled("x0_known", spelling);
  if (known.empty() && !request.x0.empty())
    throw std::invalid_argument(fmt::format("{}: the known initial state's values; give {} too", x0, x0_known));
  if (known.empty()) return {};
  if (request.refine != "ml") {
    throw std::invalid_argument(
        fmt::format("{}: acts on the refinement; {} none has none", x0_known, Spelled("refine", spelling)));
  }
  if (data.chains() != 1) {
    throw std::invalid_argument(fmt::format(
        "{}: the data have {} chains (runs, gaps or missing rows); a known initial state is one chain's", x0_known,
        data.chains()));
  }
  return {std::move(known), CheckedX0(request.x0, model, FirstSample(data), spelling)};
}

}  // namespace

void CheckRequestData(const IdentifyRequest& request) {
  CheckedKnownX0(request, request.model, request.data);
}

bool IdentifyOutcome::ok() const {
  if (refine == "ml") return refinement.result.ok();
  return recursive.flow_status == EstimatorStatus::kOk && recursive.jump_status == EstimatorStatus::kOk;
}

IdentifyOutcome RunRecursivePass(IdentifyRequest& request) {
  CheckRequest(request);
  IdentifyOutcome o(request.model);
  std::tie(o.x0_known, o.x0) = CheckedKnownX0(request, request.model, request.data);
  o.settings = CheckedSettings(request);
  o.data = std::move(request.data);
  if (!request.keep_outliers) LeaveOutOutliers(&o.data);
  o.options.trace = request.trace;
  o.options.statistics = request.statistics;
  o.options.stop = request.stop;
  o.sigma = MeasuredSigma(request);
  o.refine = request.refine;
  o.partial = Reconstruct(o.model, MeasuredIndices(o.model), o.sigma, o.data, o.options, &o.kinks);
  o.recursive = IdentifyData(o.model, o.settings, o.data, o.options);
  UseKinks(&o);
  return o;
}

void RunRecursivePassAgain(const IdentifyRequest& request, const Model& model, IdentifyOutcome* o) {
  IdentifyRequest again = request;
  again.model = model;
  o->model = model;
  o->settings = CheckedSettings(again);
  std::tie(o->x0_known, o->x0) = CheckedKnownX0(request, model, o->data);
  o->recursive = IdentifyData(model, o->settings, o->data, o->options);
  UseKinks(o);
}

void RunRefinement(const IdentifyRequest& request, IdentifyOutcome* o) {
  if (o->recursive_report.is_null())
    o->recursive_report = RecursiveJson(o->model, o->data, o->settings, request.data_accuracy_source, o->recursive);
  if (request.release_per_sample) ReleaseReported(o->recursive);
  o->refinement = RunRefineStep(request, *o);
}

SampleData ReadSampleFiles(const std::vector<std::string>& paths, const Model& model,
                           const std::vector<std::string>& columns, double max_gap, Spelling spelling) {
  std::vector<std::string> names;
  const std::vector<int> measured = MeasuredIndices(model);
  for (const int i : measured) names.push_back(model.spec().state_names[static_cast<std::size_t>(i)]);
  try {
    return ReadSampleData(paths, static_cast<int>(measured.size()),
                          {.columns = columns, .inputs = model.spec().inputs, .max_gap = max_gap,
                           .state_names = names});
  } catch (const std::invalid_argument& e) {
    std::string message = e.what();
    const std::string field = "SampleDataOptions::columns";
    if (const auto at = message.find(field); at != std::string::npos)
      message.replace(at, field.size(), Spelled("columns", spelling));
    throw std::invalid_argument(message);
  }
}

IdentifyOutcome RunIdentification(IdentifyRequest request) {
  IdentifyOutcome outcome = RunRecursivePass(request);
  RunRefinement(request, &outcome);
  return outcome;
}

std::vector<std::string> UnitNotes(const Model& model, const HybridParameters& e) {
  std::vector<std::string> notes;
  ForEachUnknown(model, e, [&](const Parameter& p, double estimate) {
    if (p.value == 0.0 || estimate == 0.0 || !std::isfinite(estimate)) return;
    const double ratio = std::abs(estimate / p.value);
    if (ratio < kUnitsFactor && ratio > 1.0 / kUnitsFactor) return;
    notes.push_back(fmt::format("{} = {:.4g} is {:.2g} times {} than its start value {:g} (the model's): check "
                                "the units of the data and of the model's values",
                                p.name, estimate, ratio >= 1.0 ? ratio : 1.0 / ratio,
                                ratio >= 1.0 ? "larger" : "smaller", p.value));
  });
  return notes;
}

}  // namespace hysid
