// Identify: the passes of one identifier over a data set (in blocks, in chains, with labels or a
// trace; the second pass), and the result: final estimates, statuses, hulls, the checks of the
// detector's bound and of the residuals, the safe start.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <utility>

#include <fmt/format.h>

#include "core/identify/events.hpp"
#include "core/identify/identifier.hpp"
#include "core/identify/identifier_state.hpp"
#include "core/identify/lockstep_units.hpp"
#include "core/identify/self_check.hpp"
#include "core/io/limits.hpp"
#include "core/model/automaton.hpp"
#include "core/model/noise_shape.hpp"

namespace hysid {

namespace {

// gtls / frisch without a noise shape: σ given or estimated from y, C averaged over up to 256 evenly
// spaced measured states (too short or non-finite data: the Identifier constructor's rule). Records
// σ and the shapes in r.
IdentifierSettings ResolveNoiseShapes(const Model& model, const Mat& y, double dt,
                                      const IdentifierSettings& settings, IdentifyResult* r) {
  IdentifierSettings resolved = settings;
  if (settings.flow_estimator.NeedsNoiseShape() || settings.jump_estimator.NeedsNoiseShape()) {
    const bool given = settings.sigma.size() != 0;
    if (given && settings.sigma.size() != model.state_size()) {
      throw std::invalid_argument(
          fmt::format("IdentifierSettings::sigma has {} entries; the model has {} states",
                      settings.sigma.size(), model.state_size()));
    }
    if (y.cols() >= 4 && y.allFinite()) {
      r->noise_sigma = given ? settings.sigma : EstimateNoiseSigma(y);
      r->noise_sigma_estimated = !given;
      const Eigen::Index count = std::min<Eigen::Index>(256, y.cols());
      Mat states(y.rows(), count);
      for (Eigen::Index i = 0; i < count; ++i) {
        states.col(i) = y.col(count > 1 ? i * (y.cols() - 1) / (count - 1) : 0);
      }
      resolved = WithNoiseShapes(model, dt, settings, r->noise_sigma, states);
    } else {
      r->noise_sigma = given ? settings.sigma : Vec::Ones(model.state_size());
      resolved = detail::ResolvedAtDefault(model, dt, settings);
    }
  }
  if (DescriptorOf(resolved.flow_estimator.kind).traits.needs_noise_shape) {
    r->flow_noise_shape = resolved.flow_estimator.noise_shape;
  }
  if (DescriptorOf(resolved.jump_estimator.kind).traits.needs_noise_shape) {
    r->jump_noise_shape = resolved.jump_estimator.noise_shape;
  }
  return resolved;
}

// Sample k's context: t_k (times, else kδt), column k of the inputs (a model with inputs), and its
// mode and the map of a jump into it (IdentifyOptions::modes, maps; else 0).
Context SampleAt(const IdentifyOptions& options, double dt, Eigen::Index k) {
  const auto u = static_cast<std::size_t>(k);
  return {.t = options.times.empty() ? static_cast<double>(k) * dt : options.times[u],
          .u = options.inputs.rows() > 0 ? options.inputs.col(k).data() : nullptr,
          .mode = options.modes.empty() ? 0 : options.modes[u],
          .map = options.maps.empty() ? 0 : options.maps[u]};
}

// The RMS of each unknown's flow (jump) regression column over up to 256 evenly spaced pairs of
// consecutive finite samples of y (flow rows at step dt); 1 for a column that is zero there. Scales
// with the data: a column in units of ξ·δt gets its RMS in those units.
void RegressorScales(const Model& model, const Mat& y, double dt, const IdentifyOptions& options, Vec* flow,
                     Vec* jump) {
  RegressionBuilder builder(model);
  const RegressionLayout& fl = builder.flow_layout();
  const RegressionLayout& jl = builder.jump_layout();
  Mat phi(fl.rows.size(), fl.unknown.size()), psi(jl.rows.size(), jl.unknown.size());
  Vec fy(fl.rows.size()), jy(jl.rows.size());
  Vec f2 = Vec::Zero(phi.cols()), j2 = Vec::Zero(psi.cols());
  double f_rows = 0.0, j_rows = 0.0;
  const Eigen::Index pairs = y.cols() - 1, count = std::min<Eigen::Index>(256, pairs);
  for (Eigen::Index i = 0; i < count; ++i) {
    const Eigen::Index k = 1 + (count > 1 ? i * (pairs - 1) / (count - 1) : 0);
    if (!y.col(k - 1).allFinite() || !y.col(k).allFinite()) continue;
    if (model.input_size() > 0) {
      const Context before = SampleAt(options, dt, k - 1), after = SampleAt(options, dt, k);
      builder.Flow(y.col(k - 1), y.col(k), dt, phi, fy, before, after);
      builder.Jump(y.col(k - 1), y.col(k), psi, jy, before);
    } else {
      builder.Flow(y.col(k - 1), y.col(k), dt, phi, fy);
      builder.Jump(y.col(k - 1), y.col(k), psi, jy);
    }
    if (phi.allFinite()) {
      f2 += phi.colwise().squaredNorm().transpose();
      f_rows += static_cast<double>(phi.rows());
    }
    if (psi.allFinite()) {
      j2 += psi.colwise().squaredNorm().transpose();
      j_rows += static_cast<double>(psi.rows());
    }
  }
  auto rms = [](const Vec& sum, double rows) {
    Vec g = (sum / std::max(rows, 1.0)).cwiseSqrt();
    for (double& v : g) v = v > 0.0 && std::isfinite(v) ? v : 1.0;
    return g;
  };
  *flow = rms(f2, f_rows);
  *jump = rms(j2, j_rows);
}

// Empty prior scales of the estimators filled from the data (RegressorScales).
IdentifierSettings WithPriorScales(const Model& model, const Mat& y, double dt,
                                   const IdentifyOptions& options, IdentifierSettings s) {
  if (y.cols() < 2 || (s.flow_estimator.prior_scale.size() && s.jump_estimator.prior_scale.size())) return s;
  Vec flow, jump;
  RegressorScales(model, y, dt, options, &flow, &jump);
  if (s.flow_estimator.prior_scale.size() == 0) s.flow_estimator.prior_scale = flow;
  if (s.jump_estimator.prior_scale.size() == 0) s.jump_estimator.prior_scale = jump;
  return s;
}

void Record(Eigen::Index k, const Decision& d, IdentifyResult* r) {
  r->gamma[static_cast<std::size_t>(k)] = d.gamma ? 1 : 0;
  if (r->statistic.empty()) return;  // IdentifyOptions::statistics off
  r->statistic[static_cast<std::size_t>(k)] = d.statistic;
  r->threshold[static_cast<std::size_t>(k)] = d.threshold;
}

// Whether every entry is finite: 0·v is 0 for a finite v and NaN for ±inf or NaN, and Eigen sums
// with vector instructions (its allFinite stops at the first non-finite entry, one entry at a time).
bool AllFinite(const Mat& y) { return (y.array() * 0.0).sum() == 0.0; }

// Irregular sampling, chains or non-finite columns: one Step per sample, with its own δt and a
// Restart at each chain start.
bool NeedsChains(const Mat& y, const IdentifyOptions& options) {
  return !options.times.empty() || !options.chain_start.empty() || options.inputs.rows() > 0 ||
         !options.modes.empty() || !AllFinite(y);
}

// Sample k fed with its label when given, and its context when there are inputs.
Decision StepAt(Identifier& id, const Mat& y, double dt, const IdentifyOptions& options, Eigen::Index k) {
  const bool labelled = !options.labels.empty();
  const bool gamma = labelled && options.labels[static_cast<std::size_t>(k)] != 0;
  if (options.inputs.rows() > 0 || !options.modes.empty()) {
    const Context at = SampleAt(options, dt, k);
    return labelled ? id.Step(y.col(k), gamma, at) : id.Step(y.col(k), at);
  }
  return labelled ? id.Step(y.col(k), gamma) : id.Step(y.col(k));
}

bool StopRaised(const IdentifyOptions& options) {
  return options.stop != nullptr && options.stop->load(std::memory_order_relaxed);
}

// Samples between two looks at IdentifyOptions::stop: fewer when hulls of n ≥ 3 states are built.
Eigen::Index StopPoll(bool sets, Eigen::Index n) {
  return sets && n >= 3 ? IdentifyOptions::kStopPollSamples / 16 : IdentifyOptions::kStopPollSamples;
}

// A column with a non-finite entry is a missing sample: skipped, and the chain goes on (the next pair
// spans it, its step from the last sample fed: times, else the count of steps of δt). False when
// stopped (IdentifyOptions::stop).
bool ChainPass(Identifier& id, const Mat& y, double dt, const IdentifyOptions& options, Eigen::Index poll,
               IdentifyResult* r) {
  r->skipped_samples = 0;
  r->chains = 0;
  bool open = false;
  Eigen::Index last = -1;  // the last sample fed in the open chain
  for (Eigen::Index k = 0; k < y.cols(); ++k) {
    const auto u = static_cast<std::size_t>(k);
    if (k % poll == 0 && StopRaised(options)) return false;
    if (!options.chain_start.empty() && options.chain_start[u] && open) {
      id.Restart();
      open = false;
    }
    if (!y.col(k).allFinite()) {
      ++r->skipped_samples;
      Record(k, Decision{}, r);
    } else {
      if (open) {
        id.SetStep(options.times.empty() ? static_cast<double>(k - last) * dt
                                         : options.times[u] - options.times[static_cast<std::size_t>(last)]);
      }
      r->chains += open ? 0 : 1;
      open = true;
      last = k;
      Record(k, StepAt(id, y, dt, options, k), r);
    }
    if (!options.trace) continue;
    r->alpha_trace.col(k) = id.alpha_hat();
    r->beta_trace.col(k) = id.beta_hat();
  }
  return true;
}

// One pass over the samples. Without a trace or labels, samples go to Feed in chunks (its block
// path); a trace needs α̂, β̂ after each sample, labels a Step with each. Looks at
// IdentifyOptions::stop every `poll` samples; false when stopped.
bool Pass(Identifier& id, const Mat& y, double dt, const IdentifyOptions& options, Eigen::Index poll,
          IdentifyResult* r) {
  if (NeedsChains(y, options)) return ChainPass(id, y, dt, options, poll, r);
  const Eigen::Index count = y.cols();
  if (!options.trace && options.labels.empty()) {
    std::vector<Decision> decisions(static_cast<std::size_t>(std::min(poll, count)));
    const FlowRows* rows =
        options.flow_rows != nullptr && !options.flow_rows->empty() ? options.flow_rows : nullptr;
    const Eigen::Index u = rows != nullptr ? static_cast<Eigen::Index>(rows->phi.size()) / count : 0;
    for (Eigen::Index k = 0; k < count; k += poll) {
      if (StopRaised(options)) return false;
      const Eigen::Index len = std::min(poll, count - k);
      if (rows != nullptr) {
        id.Feed(y.middleCols(k, len), rows->phi.data() + k * u, rows->y.data() + k, decisions.data());
      } else {
        id.Feed(y.middleCols(k, len), decisions.data());
      }
      for (Eigen::Index j = 0; j < len; ++j) Record(k + j, decisions[static_cast<std::size_t>(j)], r);
    }
    return true;
  }
  for (Eigen::Index k = 0; k < count; ++k) {
    if (k % poll == 0 && StopRaised(options)) return false;
    Record(
        k,
        options.labels.empty() ? id.Step(y.col(k)) : id.Step(y.col(k), options.labels[std::size_t(k)] != 0),
        r);
    if (!options.trace) continue;
    r->alpha_trace.col(k) = id.alpha_hat();
    r->beta_trace.col(k) = id.beta_hat();
  }
  return true;
}

// The second pass: records the first pass's outcome, re-runs, counts the changed classes. False when
// stopped.
bool SecondPass(Identifier& id, const Mat& y, double dt, const IdentifyOptions& options, Eigen::Index poll,
                IdentifyResult* r) {
  r->second_pass = true;
  r->first_pass_gamma = r->gamma;
  r->first_pass_alpha_hat = id.alpha_hat();
  r->first_pass_beta_hat = id.beta_hat();
  id.BeginSecondPass();
  if (!Pass(id, y, dt, options, poll, r)) return false;
  for (std::size_t k = 0; k < r->gamma.size(); ++k) {
    r->reclassified_to_jump += (!r->first_pass_gamma[k] && r->gamma[k]) ? 1 : 0;
    r->reclassified_to_flow += (r->first_pass_gamma[k] && !r->gamma[k]) ? 1 : 0;
  }
  return true;
}

// IdentifyOptions::stop was raised: not ok, whatever the estimates.
void MarkStopped(IdentifyResult* r) {
  r->stopped = true;
  r->flow_status = r->jump_status = EstimatorStatus::kNotExcited;
  r->flow_reason = r->jump_reason = "stopped";
}

// The hulls' vertices and volumes, looking at IdentifyOptions::stop while the n ≥ 3 hulls are finished
// (their boundary can have many facets); false, with no hulls, when stopped.
bool CollectHulls(const Identifier& id, const std::atomic<bool>* stop, IdentifyResult* r) {
  std::optional<Mat> flow = id.flow_set().vertices(stop);
  std::optional<Mat> jump = flow ? id.jump_set().vertices(stop) : std::nullopt;
  const std::optional<double> flow_volume = jump ? id.flow_set().Volume(stop) : std::nullopt;
  const std::optional<double> jump_volume = flow_volume ? id.jump_set().Volume(stop) : std::nullopt;
  if (!jump_volume) return false;
  r->flow_hull = std::move(*flow);
  r->jump_hull = std::move(*jump);
  r->flow_hull_volume = *flow_volume;
  r->jump_hull_volume = *jump_volume;
  return true;
}

// IdentifyOptions::flow_rows, when given, were built from these samples.
void CheckFlowRows(const IdentifyOptions& options, const Mat& y, double dt) {
  const FlowRows* rows = options.flow_rows;
  if (rows == nullptr || (rows->samples == y.data() && rows->count == y.cols() && rows->dt == dt)) return;
  throw std::invalid_argument(
      fmt::format("IdentifyOptions::flow_rows were built from {} samples at dt = {:g} of another matrix than "
                  "the {} samples at dt = {:g} given",
                  rows->count, rows->dt, y.cols(), dt));
}

// The final estimates, statuses, boxes and hulls; false when stopped while the hulls were finished.
bool Collect(Identifier& id, bool sets, const std::atomic<bool>* stop, IdentifyResult* r) {
  id.Finish();
  r->jumps_localized = id.jumps_localized();
  r->alpha_hat = id.alpha_hat();
  r->beta_hat = id.beta_hat();
  r->jumps_detected = id.jumps_detected();
  r->flow_status = id.flow_estimator().status();
  r->jump_status = id.jump_estimator().status();
  r->flow_reason = id.flow_estimator().reason();
  r->jump_reason = id.jump_estimator().reason();
  r->flow_box = id.flow_estimator().solution_box();
  r->jump_box = id.jump_estimator().solution_box();
  return !sets || CollectHulls(id, stop, r);
}

// The paper detector's bound checked for the whole flow at the final α̂ (CheckPaperBound), over at
// most 1024 samples spread over the run: when it cannot hold, the detected jumps include flow
// samples and the jump estimate is not ok.
void CheckDetectorBound(const Model& model, const Mat& y, const IdentifierSettings& settings,
                        IdentifyResult* r) {
  if (r->flow_status != EstimatorStatus::kOk) {  // α̂ is the prior: say why when the warm-up never ended
    if (r->flow_reason.empty() && r->jumps_detected + 1 >= y.cols()) {
      r->flow_reason = fmt::format(
          "the paper detector took every sample for a jump: its bound stays tau0 = {:g} until alpha has "
          "flow samples, and D_dt xi of these data is above it (their scale? set tau0 above D)",
          settings.detector.tau0);
    }
    return;
  }
  const Eigen::Index stride = std::max<Eigen::Index>(1, y.cols() / 1024);
  std::vector<Eigen::Index> columns;
  for (Eigen::Index k = 0; k < y.cols(); k += stride) {
    if (y.col(k).allFinite()) columns.push_back(k);
  }
  Mat points(y.rows(), static_cast<Eigen::Index>(columns.size()));
  for (std::size_t i = 0; i < columns.size(); ++i)
    points.col(static_cast<Eigen::Index>(i)) = y.col(columns[i]);
  const std::string why = CheckPaperBound(model, r->alpha_hat, settings.detector, points);
  if (why.empty() || r->jump_status != EstimatorStatus::kOk) return;
  r->jump_status = EstimatorStatus::kIllConditioned;
  r->jump_reason = why;
}

}  // namespace

namespace {

// Identify's checks of the data and the options against the model.
void CheckIdentifyInputs(const Model& model, const Mat& y, double dt, const IdentifyOptions& options) {
  if (y.rows() != model.state_size()) {
    throw std::invalid_argument(fmt::format("data has {} state rows; model '{}' has {} states", y.rows(),
                                            model.name(), model.state_size()));
  }
  if (!options.labels.empty() && static_cast<Eigen::Index>(options.labels.size()) != y.cols()) {
    throw std::invalid_argument(fmt::format("IdentifyOptions::labels has {} entries; the data has {} samples",
                                            options.labels.size(), y.cols()));
  }
  if (options.inputs.rows() != model.input_size() ||
      (model.input_size() > 0 && (options.inputs.cols() != y.cols() || !options.inputs.allFinite()))) {
    throw std::invalid_argument(fmt::format(
        "IdentifyOptions::inputs is {} × {}{}; model '{}' has {} inputs and the data {} samples",
        options.inputs.rows(), options.inputs.cols(), options.inputs.allFinite() ? "" : " (not finite)",
        model.name(), model.input_size(), y.cols()));
  }
  for (const auto& [what, size] :
       {std::pair{"times", options.times.size()}, std::pair{"chain_start", options.chain_start.size()},
        std::pair{"modes", options.modes.size()}, std::pair{"maps", options.maps.size()}}) {
    if (size != 0 && static_cast<Eigen::Index>(size) != y.cols()) {
      throw std::invalid_argument(
          fmt::format("IdentifyOptions::{} has {} entries; the data has {} samples", what, size, y.cols()));
    }
  }
  CheckFlowRows(options, y, dt);
}

// The identifier of Identify's pass (the hulls within their dimension limit, the noise shapes and
// prior scales from the data), and *r sized for the pass.
Identifier PassIdentifier(const Model& model, const Mat& y, double dt, const IdentifierSettings& settings,
                          const IdentifyOptions& options, IdentifyResult* r) {
  IdentifierSettings bounded = settings;  // the exact hulls within their dimension limit
  if (const std::int64_t max = LimitValue(kMaxHullDimension); settings.sets && model.state_size() > max) {
    bounded.sets = false;
    r->sets_skipped =
        fmt::format("{} states exceed the limit of {} {} (raise it with {}=N)", model.state_size(), max,
                    kMaxHullDimension.what, kMaxHullDimension.variable);
  }
  if (model.input_size() > 0) detail::CheckInputSettings(model, bounded);  // before the noise shapes
  Identifier id(model, dt,
                WithPriorScales(model, y, dt, options, ResolveNoiseShapes(model, y, dt, bounded, r)));
  const auto count = static_cast<std::size_t>(y.cols());
  r->gamma.resize(count);
  if (options.statistics) {
    r->statistic.resize(count);
    r->threshold.resize(count);
  }
  if (options.trace) {
    r->alpha_trace.resize(model.alpha_size(), y.cols());
    r->beta_trace.resize(model.beta_size(), y.cols());
  }
  return id;
}

// Whether the pass builds hulls (IdentifierSettings::sets within the dimension limit).
bool PassSets(const IdentifierSettings& settings, const IdentifyResult& r) {
  return settings.sets && r.sets_skipped.empty();
}

}  // namespace

IdentifyResult Identify(const Model& model, const Mat& y, double dt, const IdentifierSettings& settings,
                        const IdentifyOptions& options) {
  CheckIdentifyInputs(model, y, dt, options);
  if (options.assign_events && IsAutomaton(model.spec())) {
    if (options.flow_rows == nullptr) return IdentifyAutomaton(model, y, dt, settings, options);
    IdentifyOptions own = options;  // its passes identify other models (one per mode) on these samples
    own.flow_rows = nullptr;
    return IdentifyAutomaton(model, y, dt, settings, own);
  }
  IdentifyResult r;
  Identifier id = PassIdentifier(model, y, dt, settings, options, &r);
  const Eigen::Index poll = StopPoll(PassSets(settings, r), model.state_size());
  const bool completed = Pass(id, y, dt, options, poll, &r) &&
                         (!settings.second_pass || SecondPass(id, y, dt, options, poll, &r));
  detail::FinishIdentify(model, y, dt, settings, options, id, completed, &r);
  return r;
}

namespace detail {

bool PassInBlocks(const Model& model, const Mat& y, const IdentifyOptions& options) {
  return !(options.assign_events && IsAutomaton(model.spec())) && !NeedsChains(y, options) &&
         !options.trace && options.labels.empty();
}

Identifier StartIdentify(const Model& model, const Mat& y, double dt, const IdentifierSettings& settings,
                         const IdentifyOptions& options, IdentifyResult* r) {
  CheckIdentifyInputs(model, y, dt, options);
  return PassIdentifier(model, y, dt, settings, options, r);
}

void FinishIdentify(const Model& model, const Mat& y, double dt, const IdentifierSettings& settings,
                    const IdentifyOptions& options, Identifier& id, bool completed, IdentifyResult* r) {
  if (!completed) {
    r->alpha_hat = id.alpha_hat();  // of the samples seen
    r->beta_hat = id.beta_hat();
    r->jumps_detected = id.jumps_detected();
    MarkStopped(r);
    return;
  }
  if (!Collect(id, PassSets(settings, *r), options.stop, r)) {
    MarkStopped(r);
    return;
  }
  if (options.check_paper_bound && options.labels.empty() && settings.detector.kind == DetectorKind::kPaper)
    CheckDetectorBound(model, y, settings, r);
  if (r->flow_status != EstimatorStatus::kOk && settings.flow_estimator.kind != EstimatorKind::kRls) {
    IdentifierSettings safe = settings;
    safe.flow_estimator.kind = EstimatorKind::kRls;
    r->safe_start = std::make_shared<const IdentifyResult>(Identify(model, y, dt, safe, options));
    if (r->safe_start->stopped) MarkStopped(r);
    r->safe_start_reason =
        fmt::format("the {} estimate of alpha is {}{}{}; the refinement starts from rls (alpha {})",
                    ToString(settings.flow_estimator.kind), ToString(r->flow_status),
                    r->flow_reason.empty() ? "" : ": ", r->flow_reason, ToString(r->safe_start->flow_status));
  }
  if (r->flow_status == EstimatorStatus::kOk &&
      options.check_residuals) {  // after the safe start: not its cause
    std::string why = CheckFlowResiduals(model, y, dt, settings, options, *r);
    if (!why.empty()) {
      r->flow_status = EstimatorStatus::kInconsistent;
      r->flow_reason = std::move(why);
    }
  }
}

}  // namespace detail

const IdentifyResult& RefinementStart(const IdentifyResult& recursive) {
  return recursive.safe_start ? *recursive.safe_start : recursive;
}

}  // namespace hysid
