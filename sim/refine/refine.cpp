// The output-error refinement (sim/refine/refine.hpp): the input checks, the span retries and the fit
// from a repaired start around the one fit of sim/refine/fit.hpp.
#include "sim/refine/refine.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "core/model/automaton.hpp"
#include "core/model/noise_shape.hpp"
#include "sim/refine/fit.hpp"
#include "sim/refine/mend.hpp"
#include "sim/refine/mode_start.hpp"
#include "sim/refine/shooting.hpp"
#include "sim/refine/span.hpp"
#include "sim/refine/time_shooting.hpp"

namespace hysid {

const char* ToString(RefineStatus status) {
  switch (status) {
    case RefineStatus::kOk: return "ok";
    case RefineStatus::kNonFiniteData: return "non-finite-data";
    case RefineStatus::kTooFewSamples: return "too-few-samples";
    case RefineStatus::kStartFailed: return "start-failed";
    case RefineStatus::kNotConverged: return "not-converged";
    case RefineStatus::kZeno: return "zeno";
    case RefineStatus::kJumpCountMismatch: return "jump-count-mismatch";
    case RefineStatus::kSingularFisher: return "singular-fisher";
    case RefineStatus::kResidualRms: return "residual-rms";
    case RefineStatus::kResidualCorrelation: return "residual-correlation";
  }
  return "unknown";
}

const char* ToString(RefineRoute route) {
  switch (route) {
    case RefineRoute::kLabels: return "single shooting on the detected labels";
    case RefineRoute::kRepairedStart: return "repaired start";
    case RefineRoute::kGrownSpan: return "grown from a short span";
    case RefineRoute::kSegmentShooting: return "multiple shooting";
    case RefineRoute::kTimeShooting: return "multiple shooting by time";
  }
  return "?";
}

std::vector<RefineRoute> AllRefineRoutes() {
  return {RefineRoute::kLabels, RefineRoute::kRepairedStart, RefineRoute::kGrownSpan, RefineRoute::kSegmentShooting,
          RefineRoute::kTimeShooting};
}

std::vector<RefineRoute> RefineRoutesWithout(std::initializer_list<RefineRoute> dropped) {
  std::vector<RefineRoute> kept;
  for (RefineRoute route : AllRefineRoutes()) {
    if (route == RefineRoute::kLabels || std::find(dropped.begin(), dropped.end(), route) == dropped.end())
      kept.push_back(route);
  }
  return kept;
}

bool RefineOptions::IsValid(std::string* error) const {
  auto fail = [&](std::string what) {
    if (error) *error = std::move(what);
    return false;
  };
  if (!sensitivity.IsValid(error)) return false;
  if (!(noise_tolerance > 0.0) || !std::isfinite(noise_tolerance)) {
    return fail(fmt::format("RefineOptions::noise_tolerance = {}: must be finite and > 0", noise_tolerance));
  }
  if (!(polish_tolerance > 0.0) || !std::isfinite(polish_tolerance)) {
    return fail(
        fmt::format("RefineOptions::polish_tolerance = {}: must be finite and > 0", polish_tolerance));
  }
  if (max_iterations < 1) {
    return fail(fmt::format("RefineOptions::max_iterations = {}: must be >= 1", max_iterations));
  }
  if (!(function_tolerance > 0.0) || !(parameter_tolerance > 0.0)) {
    return fail(fmt::format("RefineOptions::function_tolerance = {}, parameter_tolerance = {}: must be > 0",
                            function_tolerance, parameter_tolerance));
  }
  if (!(rms_high > 1.0) || !std::isfinite(rms_high)) {
    return fail(fmt::format("RefineOptions::rms_high = {}: must be finite and > 1", rms_high));
  }
  if (!(residual_test_size > 0.0) || !(residual_test_size < 0.5)) {
    return fail(fmt::format("RefineOptions::residual_test_size = {}: must be in (0, 0.5)", residual_test_size));
  }
  if (!(jump_time_tolerance >= 0.0) || !std::isfinite(jump_time_tolerance)) {
    return fail(
        fmt::format("RefineOptions::jump_time_tolerance = {}: must be finite and >= 0", jump_time_tolerance));
  }
  if (max_span_retries < 0) {
    return fail(fmt::format("RefineOptions::max_span_retries = {}: must be >= 0", max_span_retries));
  }
  if (shooting_jumps < 1) {
    return fail(fmt::format("RefineOptions::shooting_jumps = {}: must be >= 1", shooting_jumps));
  }
  if (min_jump_interval < 0) {
    return fail(fmt::format("RefineOptions::min_jump_interval = {}: must be >= 0", min_jump_interval));
  }
  if (sigma.size() != 0 && (!sigma.allFinite() || (sigma.array() < 0.0).any())) {
    return fail("RefineOptions::sigma: every entry must be finite and >= 0");
  }
  const std::vector<RefineRoute> all = AllRefineRoutes();
  auto next = all.begin();
  for (RefineRoute route : routes) {
    next = std::find(next, all.end(), route);
    if (next == all.end()) {
      return fail(fmt::format("RefineOptions::routes: '{}' out of order or repeated: the routes are tried in "
                              "AllRefineRoutes' order, each once",
                              ToString(route)));
    }
    ++next;
  }
  if (routes.empty() || routes.front() != RefineRoute::kLabels) {
    return fail(fmt::format("RefineOptions::routes: must begin with '{}'", ToString(RefineRoute::kLabels)));
  }
  return true;
}

namespace {

void CheckChain(const Model& model, const RefineChain& c, std::size_t index) {
  if (c.y.rows() != model.state_size() || static_cast<Eigen::Index>(c.t.size()) != c.y.cols() ||
      c.gamma.size() != c.t.size()) {
    throw std::invalid_argument(fmt::format(
        "Refine: chain {}: y is {} × {}, {} times, gamma has {} entries; model '{}' has {} states", index + 1,
        c.y.rows(), c.y.cols(), c.t.size(), c.gamma.size(), model.name(), model.state_size()));
  }
  if (c.u.rows() != model.input_size() ||
      (c.u.rows() > 0 && (c.u.cols() != c.y.cols() || !c.u.allFinite()))) {
    throw std::invalid_argument(
        fmt::format("Refine: chain {}: u is {} × {}{}; model '{}' has {} inputs and the chain {} samples",
                    index + 1, c.u.rows(), c.u.cols(), c.u.allFinite() ? "" : " (not finite)", model.name(),
                    model.input_size(), c.y.cols()));
  }
  for (std::size_t k = 1; k < c.t.size(); ++k) {
    if (!(c.t[k] > c.t[k - 1]) || !std::isfinite(c.t[k])) {
      throw std::invalid_argument(
          fmt::format("Refine: chain {}: time {} after {}: must increase", index + 1, c.t[k], c.t[k - 1]));
    }
  }
  const int modes = ModeCount(model.spec()), maps = static_cast<int>(JumpMaps(model.spec()).size());
  if (c.initial_mode < -1 || c.initial_mode >= modes) {
    throw std::invalid_argument(fmt::format("Refine: chain {}: initial_mode {} outside [-1, {})", index + 1,
                                            c.initial_mode, modes));
  }
  for (const int m : c.maps) {
    if (m < 0 || m >= maps) {
      throw std::invalid_argument(fmt::format("Refine: chain {}: map {} outside [0, {})", index + 1, m, maps));
    }
  }
}

void CheckKnownX0(const Model& model, std::size_t chains, const RefineOptions& options) {
  const std::vector<int>& known = options.x0_known;
  if (known.empty()) return;
  for (std::size_t i = 0; i < known.size(); ++i) {
    if (known[i] < 0 || known[i] >= model.state_size() || (i > 0 && known[i] <= known[i - 1])) {
      throw std::invalid_argument(fmt::format("RefineOptions::x0_known: entry {} = {}: must increase within [0, {})",
                                              i + 1, known[i], model.state_size()));
    }
  }
  if (options.x0.size() != model.state_size() || !options.x0.allFinite()) {
    throw std::invalid_argument(fmt::format("RefineOptions::x0 has {} entries (finite): the model has {} states",
                                            options.x0.size(), model.state_size()));
  }
  if (chains != 1) {
    throw std::invalid_argument(fmt::format(
        "RefineOptions::x0_known: the data have {} chains; a known initial state is one chain's", chains));
  }
}

void CheckInputs(const Model& model, const std::vector<RefineChain>& chains, const Vec& alpha0,
                 const Vec& beta0, const RefineOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument(error);
  if (alpha0.size() != model.alpha_size() || beta0.size() != model.beta_size()) {
    throw std::invalid_argument("Refine: alpha0/beta0 must be the model's full parameter vectors");
  }
  const auto& measured = options.measured;
  for (std::size_t i = 0; i < measured.size(); ++i) {
    if (measured[i] < 0 || measured[i] >= model.state_size() || (i > 0 && measured[i] <= measured[i - 1])) {
      throw std::invalid_argument(fmt::format(
          "RefineOptions::measured: entry {} = {}: must increase within [0, {})", i + 1, measured[i],
          model.state_size()));
    }
  }
  const auto rows = static_cast<Eigen::Index>(measured.empty() ? model.state_size() : measured.size());
  if (options.sigma.size() != 0 && options.sigma.size() != rows) {
    throw std::invalid_argument(fmt::format("RefineOptions::sigma has {} entries; {} states are measured",
                                            options.sigma.size(), rows));
  }
  for (std::size_t c = 0; c < chains.size(); ++c) CheckChain(model, chains[c], c);
  CheckKnownX0(model, chains.size(), options);
}

// The first non-finite sample ("chain c " when several, "sample k component i is v"), or "" when all
// are finite.
std::string FirstNonFinite(const std::vector<RefineChain>& chains) {
  for (std::size_t c = 0; c < chains.size(); ++c) {
    const SampleView& y = chains[c].y;
    for (Eigen::Index k = 0; k < y.cols(); ++k) {
      for (Eigen::Index i = 0; i < y.rows(); ++i) {
        if (std::isfinite(y(i, k))) continue;
        return fmt::format("{}sample {} component {} is {}",
                           chains.size() > 1 ? fmt::format("chain {} ", c + 1) : "", k, i + 1, y(i, k));
      }
    }
  }
  return "";
}

// The options of the repaired start's weighting, over all n rows of the chains: σ estimated (the MAD
// of every row) when only some states are measured (RefineOptions::sigma then has the measured ones).
RefineOptions StartWeighting(const RefineOptions& options) {
  RefineOptions o = options;
  if (!options.measured.empty()) o.sigma.resize(0);
  return o;
}

// The fit from s; while it fails because a chain's model and its detected jumps disagree (a jump the
// detector missed, or one it added), that chain's span is cut to end SpanMargin samples before the
// first disagreement and the chains are fit again, at most max_span_retries times per chain. A retry
// that fails for another reason leaves the failure before it. *first_used: the samples of the first fit.
RefineResult FitWithRetries(const Model& model, const std::vector<RefineChain>& chains, FitStart s,
                            const RefineOptions& options, long* first_used) {
  ChainFailure failure;
  RefineResult r = FitChains(model, chains, s, options, &failure);
  *first_used = r.samples_used;
  std::vector<int> retries(chains.size(), 0);
  std::vector<std::uint8_t> mended(chains.size(), 0);
  const long margin = SpanMargin(options), shortest = 2L * model.state_size() + 2;
  while (SpanRetryable(r.status) && failure.chain >= 0 && !options.stopped()) {
    const auto c = static_cast<std::size_t>(failure.chain);
    if (options.mend_detections && !mended[c] && !failure.model_jumps.empty()) {
      mended[c] = 1;
      const long reach = static_cast<long>(std::ceil(options.jump_time_tolerance)) + 1;
      if (MendFromFit(model, chains, options, failure, reach, s, r)) break;
    }
    const long used = r.chain_samples_used[c], shorter = failure.disagreement - margin;
    if (retries[c] == options.max_span_retries || failure.disagreement < 0 || shorter >= used ||
        shorter < shortest) {
      break;
    }
    ++retries[c];
    s.limit[c] = shorter;
    s.reason[c] = SpanRetryReason(used, r.status, failure.disagreement);
    RefineResult next = FitChains(model, chains, s, options, &failure);
    if (!next.ok() && !SpanRetryable(next.status)) break;  // the failure before this retry is reported
    r = std::move(next);
  }
  // Ok only on cut spans: carried to the whole chains when the fitted model's jumps are in the data.
  if (options.mend_detections && r.ok() && r.samples_used < *first_used) SettleAtModelJumps(model, chains, options, false, s, r);
  return r;
}

// The first span of a growing fit: the samples before the third detected jump (all when fewer), never
// fewer than `shortest`.
long FirstGrowingSpan(const std::vector<std::uint8_t>& gamma, long shortest, long margin) {
  const auto k_count = static_cast<long>(gamma.size());
  int seen = 0;
  for (long k = 1; k < k_count; ++k) {
    if (gamma[static_cast<std::size_t>(k)] != 0 && ++seen == 3) return std::max(shortest, k - margin);
  }
  return k_count;
}

// One step of a growing fit after the ok fit r from s: each chain's span grown by half (up to all its
// samples), its labels over the grown span mended from r's model there. false when every span is whole.
bool GrowStep(const Model& model, const std::vector<RefineChain>& chains, const RefineResult& r,
              const RefineOptions& options, FitStart* s) {
  const long reach = static_cast<long>(std::ceil(options.jump_time_tolerance)) + 1;
  s->start.alpha = r.refined.alpha;
  s->start.beta = r.refined.beta;
  s->start.gamma = r.refined.gamma;
  bool longer = false;
  for (std::size_t c = 0; c < chains.size(); ++c) {
    const long k_count = chains[c].y.cols();
    if (r.chain_x0[c].size() == 0 || s->limit[c] >= k_count) continue;
    s->x0[c] = r.chain_x0[c];
    s->limit[c] = std::min(k_count, s->limit[c] + s->limit[c] / 2);
    s->reason[c] = s->limit[c] < k_count ? "the span grows" : "";
    const std::vector<double> jumps = ModelJumps(model, chains[c], r.refined, s->x0[c], s->limit[c], options);
    std::string what;
    MendFromModel(chains[c], "", s->limit[c], jumps, reach, &s->gamma[c], &what);
    longer = true;
  }
  return longer;
}

// Re-placements of the grown fit's labels by its local flows.
constexpr int kMaxSettle = 4;

// A growing fit on spans short of the whole chains is only the next one's start, and jump times fit
// on a short span are uncertain by a few samples: its jumps are checked at this multiple of
// RefineOptions::jump_time_tolerance (the fit on all samples at jump_time_tolerance itself).
constexpr double kGrowingJumpTolerance = 1.5;

// The options of a growing fit from s: the looser jump-time check while a chain's span is short of
// all its samples.
RefineOptions GrowingOptions(const std::vector<RefineChain>& chains, const FitStart& s,
                             const RefineOptions& options) {
  RefineOptions part = options;
  for (std::size_t c = 0; c < chains.size(); ++c) {
    if (s.limit[c] < chains[c].y.cols()) {
      part.jump_time_tolerance *= kGrowingJumpTolerance;
      break;
    }
  }
  return part;
}

// After the ok fit r from s: each chain's labels placed where the local flows of r's α meet best
// (RepairStart from r: a label moves to the sample where the flows fit on either side meet, one the
// flows do not need is dropped, a jump r's model makes and the data show is added). false when none
// changes.
bool SettleLabels(const Model& model, const std::vector<RefineChain>& chains, const RefineResult& r,
                  const RefineOptions& options, FitStart* s) {
  if (model.input_size() > 0) return false;  // the local flows of RepairStart run without inputs
  const Mat y = Concatenated(chains, model.state_size());
  SensitivityOptions sens;
  Vec weight;
  FitWeighting(y, StartWeighting(options), EstimateNoiseSigma(y), &sens, &weight);
  bool moved = false;
  for (std::size_t c = 0; c < chains.size(); ++c) {
    const RefineChain& in = chains[c];
    if (r.chain_x0[c].size() == 0 || in.y.cols() < 2) continue;
    const double dt = (in.t.back() - in.t.front()) / static_cast<double>(in.y.cols() - 1);
    const HybridParameters from{r.refined.alpha, r.refined.beta, r.chain_x0[c], r.refined.gamma};
    const StartRepair repair =
        RepairStart(model, in.y, dt, s->gamma[c], from, r.unknowns, weight, sens, options.start_repair);
    if (!repair.ok || repair.gamma == s->gamma[c]) continue;
    s->gamma[c] = repair.gamma;
    moved = true;
  }
  if (!moved) return false;
  MoveTo(r, *s);
  return true;
}

// A settled fit r whose start failed (its labels outnumber its start's jumps: the local flows split
// one jump in two): its labels mended from the model of the fit it settled from, `kept` (a label with
// no model jump within ⌈jump_time_tolerance⌉ + 1 samples dropped, a model jump with no label added,
// the others kept), adopted when that fit passes every check.
void MendSettledStart(const Model& model, const std::vector<RefineChain>& chains,
                      const RefineOptions& options, const RefineResult& kept, ChainFailure failure,
                      FitStart& s, RefineResult& r) {
  if (r.status != RefineStatus::kStartFailed || failure.chain < 0 || !failure.model_jumps.empty()) return;
  const auto c = static_cast<std::size_t>(failure.chain);
  failure.model_jumps = ModelJumps(model, chains[c], kept.refined, kept.chain_x0[c], s.limit[c], options);
  MendFromFit(model, chains, options, failure, static_cast<long>(std::ceil(options.jump_time_tolerance)) + 1,
              s, r);
}

// The fit grown from a short span (RefineRoute::kGrownSpan): the chains fit on the samples before
// their third detected jump from s, then again and again on spans half as long again, from the
// previous fit with the labels of each grown part mended from its model, until every chain is whole;
// then the labels settled by the local flows (a settled start that fails mended from the model it
// settled from; and, `follow_settled`, following the settled fit's own jumps when they leave them).
// The last fit, on all samples, with every check; its status is the first failure otherwise.
RefineResult GrowSpan(const Model& model, const std::vector<RefineChain>& chains, FitStart s,
                      const RefineOptions& options, bool follow_settled) {
  const long shortest = 2L * model.state_size() + 2, margin = SpanMargin(options);
  for (std::size_t c = 0; c < chains.size(); ++c) s.limit[c] = FirstGrowingSpan(s.gamma[c], shortest, margin);
  ChainFailure failure;
  RefineOptions growing = GrowingOptions(chains, s, options);
  RefineResult r = FitChains(model, chains, s, growing, &failure);
  if (!r.ok() && SpanRetryable(r.status)) MendFromFit(model, chains, growing, failure, 0, s, r);
  while (r.ok() && GrowStep(model, chains, r, options, &s)) {
    growing = GrowingOptions(chains, s, options);
    r = FitChains(model, chains, s, growing, &failure);
    // A grown fit whose jumps moved off their labels: its labels placed at its model's own jumps
    // (reach 0: a detection a few samples off moves there) and fit again, in rounds.
    if (!r.ok() && SpanRetryable(r.status)) MendFromFit(model, chains, growing, failure, 0, s, r);
  }
  // Settled: the labels placed where the fit's local flows meet, fit again until none moves.
  // A settled fit whose jumps then leave their labels has them follow its model's own (in rounds)
  // when `follow_settled`.
  for (int settle = 0; r.ok() && settle < kMaxSettle && SettleLabels(model, chains, r, options, &s);
       ++settle) {
    const RefineResult kept = r;
    r = FitChains(model, chains, s, options, &failure);
    MendSettledStart(model, chains, options, kept, failure, s, r);
    if (follow_settled && !r.ok() && SpanRetryable(r.status)) MendFromFit(model, chains, options, failure, 0, s, r);
  }
  if (!r.ok()) return r;
  int added = 0, dropped = 0;
  for (std::size_t c = 0; c < chains.size(); ++c) {
    for (std::size_t k = 1; k < chains[c].gamma.size(); ++k) {
      added += s.gamma[c][k] != 0 && chains[c].gamma[k] == 0 ? 1 : 0;
      dropped += s.gamma[c][k] == 0 && chains[c].gamma[k] != 0 ? 1 : 0;
    }
  }
  r.mended = fmt::format("grown from a short span: {} added, {} dropped", added, dropped);
  return r;
}

// The fit by multiple shooting (RefineRoute::kSegmentShooting, sim/refine/shooting.hpp): the
// chains by single shooting (with the retries) from the segments' fit. Its status is the segments'
// failure when they are not fit, else the single-shooting fit's.
RefineResult FitShooting(const Model& model, const std::vector<RefineChain>& chains, const FitStart& s,
                         const RefineOptions& options) {
  RefineResult shot;
  FitStart joined;
  if (!ShootSegments(model, chains, s, options, &shot, &joined)) return shot;
  // The labels placed at the single-shooting fit's own jumps while they disagree with its model's.
  ChainFailure failure;
  RefineResult r = FitChains(model, chains, joined, options, &failure);
  for (int round = 0; round < kShootingRounds && SpanRetryable(r.status) && failure.chain >= 0 &&
                      !failure.model_jumps.empty() && !options.stopped();
       ++round) {
    const auto c = static_cast<std::size_t>(failure.chain);
    MoveTo(r, joined);
    std::string what;
    if (!MendFromModel(chains[c], "", r.chain_samples_used[c], failure.model_jumps, 0, &joined.gamma[c], &what)) break;
    r = FitChains(model, chains, joined, options, &failure);
  }
  long used = 0;
  if (!r.ok()) r = FitWithRetries(model, chains, joined, options, &used);
  // The labels a detector placed a few samples off, or missed, placed at the fit's own jumps.
  if (options.mend_detections) SettleAtModelJumps(model, chains, options, true, joined, r);
  r.mended = r.mended.empty() ? shot.mended : shot.mended + "; " + r.mended;
  return r;
}

// The fit `other` by another route replaces r when it is ok and fits more samples (its start then
// r's); else, when r is not ok, r's reason says how `route` ended.
void AdoptRoute(RefineResult& r, RefineResult other, RefineRoute route) {
  if (other.ok() && other.samples_used > (r.ok() ? r.samples_used : 0)) {
    other.start = r.start;
    other.route = ToString(route);
    r = std::move(other);
  } else if (!r.ok()) {
    r.reason += fmt::format("; {}: {}", ToString(route), other.ok() ? "ok on fewer samples" : other.reason);
  }
}

// A fit at the noise on `samples` (every sample it could fit) whose information is singular: a
// direction of the unknowns the data do not determine at that point, which no other start changes.
bool SingularAtTheNoise(const RefineResult& r, long samples) {
  return r.status == RefineStatus::kSingularFisher && r.at_the_noise && r.samples_used >= samples;
}

// Whether the fit r, not ok or ok only on cut spans (`first_used` samples before the cuts), may be
// bettered by a fit from another start.
bool MayBetter(const RefineResult& r, long first_used, const RefineOptions& options) {
  return (!r.ok() || r.samples_used < first_used) && !options.stopped() &&
         r.status != RefineStatus::kTooFewSamples && !SingularAtTheNoise(r, first_used);
}

// γ's start: one Newton step from the model's γ over the detected jumps of every chain
// (AppendGuardRows, SolveGuardRows in sim/refine/start.hpp).
Vec GuardStart(const Model& model, const std::vector<RefineChain>& chains, const Vec& alpha0) {
  const Unknowns unknowns = Unknowns::Of(model);
  Mat rows(0, static_cast<Eigen::Index>(unknowns.gamma.size()));
  Vec rhs(0);
  for (const RefineChain& c : chains) {
    AppendGuardRows(model, c.t, c.y, c.gamma, alpha0, model.gamma(), unknowns, &rows, &rhs, c.maps,
                    c.initial_mode, c.u);
  }
  return SolveGuardRows(unknowns, rows, rhs, model.gamma());
}

// p with its unknown α, β and γ entries moved onto the nearest bound where they lie outside theirs (a
// start the data give; a value the user gives outside its bounds is refused where it is given).
HybridParameters WithinBounds(const Model& model, HybridParameters p) {
  const Unknowns u = Unknowns::Of(model);
  const std::vector<const Parameter*> params = u.Parameters(model);
  std::size_t k = 0;
  for (auto [indices, values] : {std::pair{&u.alpha, &p.alpha}, std::pair{&u.beta, &p.beta},
                                 std::pair{&u.gamma, &p.gamma}}) {
    for (int i : *indices) {
      const Parameter& bound = *params[k++];
      (*values)[i] = std::clamp((*values)[i], bound.lower, bound.upper);
    }
  }
  return p;
}

// The recursive start: α0, β0, γ from the detected jumps, each chain's detected labels and its first
// sample, all samples allowed.
FitStart RecursiveStart(const Model& model, const std::vector<RefineChain>& chains, const Vec& alpha0,
                        const Vec& beta0) {
  const int n = model.state_size();
  auto first = [n](const RefineChain& c) { return c.y.cols() > 0 ? Vec(c.y.col(0)) : Vec::Zero(n).eval(); };
  FitStart s;
  s.start = WithinBounds(model, HybridParameters{alpha0, beta0,
                                                 chains.empty() ? Vec::Zero(n).eval() : first(chains[0]),
                                                 GuardStart(model, chains, alpha0)});
  for (const RefineChain& c : chains) {
    s.gamma.push_back(c.gamma);
    s.x0.push_back(first(c));
    s.limit.push_back(c.y.cols());
    s.reason.emplace_back();
  }
  return s;
}

// The rows of one chain's β regression appended to the stacked ones.
void AppendRows(const StartRepair& repair, Mat& rows, Vec& rhs) {
  const Eigen::Index m = rows.rows(), add = repair.jump_rows.rows();
  rows.conservativeResize(m + add, repair.jump_rows.cols());
  rhs.conservativeResize(m + add);
  rows.bottomRows(add) = repair.jump_rows;
  rhs.tail(add) = repair.jump_rhs;
}

// The repaired start (sim/refine/start.hpp): RepairStart on each chain that can be fit (all its
// samples, read as a grid at the chain's mean step: the repair is only a start, the fit reads each
// sample at its own time) gives that chain's labels and initial state; α stays the recursive α̂, β's
// unknown entries solve all chains' jump regressions stacked. false when no chain is repaired;
// *summary: the changes summed over the chains, and (several chains) the chains changed.
bool RepairChains(const Model& model, const std::vector<RefineChain>& chains, const FitStart& recursive,
                  const RefineOptions& options, FitStart* out, std::string* summary) {
  const Mat y = Concatenated(chains, model.state_size());
  SensitivityOptions sens;
  Vec weight;
  FitWeighting(y, StartWeighting(options), EstimateNoiseSigma(y), &sens, &weight);
  const Unknowns unknowns = Unknowns::Of(model);
  *out = recursive;
  StartRepair total;
  Mat rows(0, static_cast<Eigen::Index>(unknowns.beta.size()));
  Vec rhs(0);
  std::vector<std::size_t> changed;
  for (std::size_t c = 0; c < chains.size(); ++c) {
    const RefineChain& in = chains[c];
    const long k_count = in.y.cols();
    if (!LeftOut(model, in, k_count, recursive.start.gamma).empty()) continue;
    const double dt = (in.t.back() - in.t.front()) / static_cast<double>(k_count - 1);
    const HybridParameters from{recursive.start.alpha, recursive.start.beta, in.y.col(0),
                                recursive.start.gamma};
    const StartRepair repair =
        RepairStart(model, in.y, dt, in.gamma, from, unknowns, weight, sens, options.start_repair);
    if (!repair.ok) continue;
    out->gamma[c] = repair.gamma;
    out->x0[c] = repair.start.x0;
    AppendRows(repair, rows, rhs);
    total.dropped += repair.dropped;
    total.moved += repair.moved;
    total.added += repair.added;
    if (repair.dropped + repair.moved + repair.added > 0) changed.push_back(c + 1);
    total.ok = true;
  }
  if (!total.ok) return false;
  out->start.beta = SolveJumpRows(unknowns, rows, rhs, recursive.start.beta);
  out->start = WithinBounds(model, out->start);
  *summary = total.Summary();
  if (chains.size() > 1 && !changed.empty()) {
    *summary += fmt::format("; detections changed in chain{} {}", changed.size() > 1 ? "s" : "",
                            fmt::join(changed, ", "));
  }
  return true;
}

}  // namespace

RefineChain RefineChain::Of(std::vector<double> t, Mat y, std::vector<std::uint8_t> gamma, Mat u) {
  RefineChain c;
  c.t = std::move(t);
  c.gamma = std::move(gamma);
  auto owned = std::make_shared<Samples>(Samples{std::move(y), std::move(u)});
  c.y = SampleView(owned->y);
  c.u = SampleView(owned->u);
  c.owned = std::move(owned);
  return c;
}

RefineChain RefineChain::Uniform(const Mat& y, double dt, const std::vector<std::uint8_t>& gamma) {
  std::vector<double> t(static_cast<std::size_t>(y.cols()));
  for (std::size_t k = 0; k < t.size(); ++k) t[k] = static_cast<double>(k) * dt;
  return Of(std::move(t), y, gamma);
}

namespace {

// Samples [begin, end) of (t, y, gamma, u) as one chain: a view of y's and u's columns when all are
// finite, else a copy of the finite ones (none: an empty chain).
RefineChain ChainOf(const std::vector<double>& t, const Mat& y, const std::vector<std::uint8_t>& gamma,
                    const Mat& u, std::size_t begin, std::size_t end) {
  std::size_t present = 0;
  for (std::size_t k = begin; k < end; ++k) present += y.col(static_cast<Eigen::Index>(k)).allFinite() ? 1 : 0;
  const auto first = static_cast<Eigen::Index>(begin), count = static_cast<Eigen::Index>(end - begin);
  if (present == end - begin) {
    RefineChain c;
    c.t.assign(t.begin() + first, t.begin() + first + count);
    c.y = SampleView(y, first, count);
    c.gamma.assign(gamma.begin() + first, gamma.begin() + first + count);
    c.u = SampleView(u, u.rows() > 0 ? first : 0, u.rows() > 0 ? count : 0);
    return c;
  }
  std::vector<double> ct;
  std::vector<std::uint8_t> cg;
  ct.reserve(present);
  cg.reserve(present);
  Mat cy(y.rows(), static_cast<Eigen::Index>(present)), cu(u.rows(), u.rows() > 0 ? cy.cols() : 0);
  for (std::size_t k = begin; k < end; ++k) {
    const auto kk = static_cast<Eigen::Index>(k);
    if (!y.col(kk).allFinite()) continue;
    const auto i = static_cast<Eigen::Index>(ct.size());
    ct.push_back(t[k]);
    cg.push_back(gamma[k]);
    cy.col(i) = y.col(kk);
    if (u.rows() > 0) cu.col(i) = u.col(kk);
  }
  return RefineChain::Of(std::move(ct), std::move(cy), std::move(cg), std::move(cu));
}

}  // namespace

std::vector<RefineChain> SplitChains(const std::vector<double>& t, const Mat& y,
                                     const std::vector<std::uint8_t>& chain_start,
                                     const std::vector<std::uint8_t>& gamma, const Mat& u) {
  const auto k_count = static_cast<std::size_t>(y.cols());
  if (t.size() != k_count || (!chain_start.empty() && chain_start.size() != k_count) ||
      gamma.size() != k_count || (u.rows() > 0 && static_cast<std::size_t>(u.cols()) != k_count)) {
    throw std::invalid_argument(
        fmt::format("SplitChains: {} samples, {} times, {} chain_start, {} gamma entries, {} input samples",
                    k_count, t.size(), chain_start.size(), gamma.size(), u.cols()));
  }
  std::vector<RefineChain> chains;
  std::size_t begin = 0;
  for (std::size_t k = 1; k <= k_count; ++k) {
    if (k < k_count && (chain_start.empty() || !chain_start[k])) continue;
    RefineChain c = ChainOf(t, y, gamma, u, begin, k);
    if (!c.t.empty()) chains.push_back(std::move(c));
    begin = k;
  }
  return chains;
}

namespace {

// singular-fisher at the noise with what the data determine (RefineResult::determined_standard_errors):
// no other start changes that.
bool Determines(const RefineResult& r) { return r.determined_standard_errors.size() != 0; }

// Whether fit a is better than fit b: ok before not ok, then reported before not, then one that
// Determines, then the lower final cost (the same data and weights, so the higher likelihood).
bool Better(const RefineResult& a, const RefineResult& b) {
  if (a.ok() != b.ok()) return a.ok();
  if (a.reported != b.reported) return a.reported;
  if (Determines(a) != Determines(b)) return Determines(a);
  return a.reported && a.final_cost < b.final_cost;
}

// The starts of multiple shooting by time, in order: with `span_fit` (the labelled routes' fit, ok on
// spans that leave samples out) its estimate, its fit kept at once when ok (it is at the optimum of
// most of the data, where a far start of the model's own values can take seconds to come from); the
// model's own values (a model file's start values), its fit kept at once when ok, then the recursive
// estimate; while no fit is ok, for
// an automaton with a hidden mode, α of the modes the data show (ModeClusteredAlpha, with the model's own β
// and γ); with `search` (the labelled routes reported nothing) while no fit can be reported (every one
// singular, unconverged or failed: a start in another basin, or whose guards the model never reaches), the
// model's values with γ where the guards are reached (GammaReachingGuards), then the points of a Halton
// design over the box the model's values span (DesignStarts), each with γ where its guards are reached,
// until one is ok (their fits are kept only when ok); the same search when the best fit is refused by its
// residual tests although some start's nearly free segments fit the data to the noise
// (RefineResult::segments_fit_noise: a local minimum, not model error), a fit kept only when ok at a lower
// cost. The searching starts hold a hidden state whose node starts all take one value (a constant the
// data do not reconstruct) continuous from the first width on (FitByTimeShooting's tie_flat_hidden):
// free per segment, it trades for the parameters it enters with. A fit that Determines ends the starts
// (and a searching start's is kept) as an ok one does. The best of the fits (Better); `mended` names
// the start of the one kept.
RefineResult TimeShootingFromStarts(const Model& model, const std::vector<RefineChain>& chains,
                                    const HybridParameters& recursive, const RefineOptions& options, bool search,
                                    const HybridParameters* span_fit) {
  auto named = [](RefineResult fit, const std::string& start) {
    if (!fit.mended.empty()) fit.mended += " from " + start;
    return fit;
  };
  HybridParameters own = recursive;
  own.alpha = model.alpha();
  own.beta = model.beta();
  own.gamma = model.gamma();
  // A searching start (guards reached, the design) is kept only when ok: a refused fit from a point
  // of the box says nothing the first starts' fits did not.
  RefineResult best;
  auto consider = [&](RefineResult other, bool only_ok = false) {
    if ((!only_ok || other.ok() || Determines(other)) && Better(other, best)) {
      other.start = recursive;
      best = std::move(other);
    }
  };
  auto fit = [&](const HybridParameters& from, const std::string& what, bool tie_flat_hidden = false) {
    return named(FitByTimeShooting(model, chains, from, options, tie_flat_hidden), what);
  };
  // The labelled fit on its spans first, when there is one: its fit, when ok, is kept.
  std::optional<RefineResult> from_span;
  if (span_fit != nullptr && !options.stopped()) {
    from_span = fit(*span_fit, "the labelled fit on its spans");
    if (from_span->ok()) {
      consider(std::move(*from_span));
      return best;
    }
  }
  // Then the model's values, each fit with every thread on its segments: its fit, when ok, is kept;
  // else the recursive estimate's is fit and the best of the fits kept (Better, in this order). Each
  // fit is deterministic, so the result does not depend on the threads.
  const bool own_differs =
      own.alpha != recursive.alpha || own.beta != recursive.beta || own.gamma != recursive.GammaOr(model);
  std::optional<RefineResult> from_own;
  if (own_differs && !options.stopped()) {
    from_own = fit(own, "the model's values");
    if (from_own->ok()) {
      consider(std::move(*from_own));
      return best;
    }
  }
  best = fit(recursive, "the recursive estimate");
  bool segments_fit_noise = best.segments_fit_noise || (from_own && from_own->segments_fit_noise) ||
                            (from_span && from_span->segments_fit_noise);
  if (from_own) consider(std::move(*from_own));
  if (from_span) consider(std::move(*from_span));
  if (best.ok() || Determines(best) || options.stopped()) return best;
  const int n = model.state_size();
  long samples = 0;
  for (const RefineChain& c : chains) samples += static_cast<long>(c.t.size());
  const long window = std::max(2L * n + 2, TimeShootingNodeSpacing(samples, n) / 4);
  if (const std::optional<Vec> alpha =
          ModeClusteredAlpha(model, chains, MeasuredRows(options, n), own, Unknowns::Of(model), window)) {
    HybridParameters clustered = own;
    clustered.alpha = *alpha;
    RefineResult other = fit(clustered, "the modes the data show");
    segments_fit_noise = segments_fit_noise || other.segments_fit_noise;
    consider(std::move(other));
  }
  // A refused fit although some start's free segments fit the data to the noise: a local minimum,
  // searched like a start that reports nothing.
  const bool local_minimum = best.reported && !best.ok() && segments_fit_noise;
  if (!(local_minimum || (search && !best.reported)) || options.stopped()) return best;
  // The searching starts in order, a batch side by side; the first ok one is kept, so the result is
  // the same whatever the batch (a batch's later fits are then work spent for nothing).
  struct Searching {
    HybridParameters from;
    std::string name;
    bool reach = false;  // its guards reached (GammaReachingGuards) before its fit
  };
  std::vector<Searching> searching;
  if (const std::optional<Vec> gamma = GammaReachingGuards(model, chains, own, options)) {
    searching.push_back({own, "the model's values with its guards reached"});
    searching.back().from.gamma = *gamma;
  }
  const std::vector<HybridParameters> design = DesignStarts(model, own, kDesignStarts, kDesignFactor);
  for (std::size_t k = 0; k < design.size(); ++k) {
    searching.push_back({design[k], fmt::format("design point {} of {}", k + 1, design.size()), true});
  }
  // Whether a searching start's fit is kept and ends the search: ok or Determines, better than the
  // best so far, and out of a local minimum to a lower cost (the same data and weights, a higher
  // likelihood). `best` does not change within a batch until a fit ends the search.
  auto ends_search = [&](const RefineResult& other) {
    return (other.ok() || Determines(other)) && Better(other, best) &&
           (!local_minimum || other.final_cost < best.final_cost);
  };
  const auto batch =
      static_cast<std::size_t>(std::clamp(tbb::this_task_arena::max_concurrency(), 1, kSearchBatch));
  for (std::size_t first = 0;
       first < searching.size() && !best.ok() && !Determines(best) && !options.stopped(); first += batch) {
    const std::size_t size = std::min(batch, searching.size() - first);
    std::vector<std::optional<RefineResult>> fits(size);
    // A fit that ends the search cancels the batch's later ones (their fits are never kept); the
    // earlier ones run on, so the kept fit is the first in order that ends it, whatever the threads.
    std::vector<std::atomic<bool>> cancel(size);
    tbb::parallel_for(std::size_t{0}, size, [&](std::size_t k) {
      if (cancel[k].load()) return;
      Searching& at = searching[first + k];
      RefineOptions own_options = options;
      own_options.cancel = own_options.sensitivity.sim.cancel = &cancel[k];
      const std::optional<Vec> gamma =
          at.reach ? GammaReachingGuards(model, chains, at.from, own_options) : std::nullopt;
      if (gamma) at.from.gamma = *gamma;
      fits[k] = named(FitByTimeShooting(model, chains, at.from, own_options, /*tie_flat_hidden=*/true), at.name);
      if (!cancel[k].load() && ends_search(*fits[k])) {
        for (std::size_t j = k + 1; j < size; ++j) cancel[j].store(true);
      }
    });
    for (std::size_t k = 0; k < size && !best.ok() && !Determines(best); ++k) {
      if (ends_search(*fits[k])) consider(std::move(*fits[k]), true);
    }
  }
  return best;
}

// The time-shooting fit replaces r when it is ok and r is not, or is ok on fewer samples; when r is
// not reported and it is; or when neither is and it Determines and r does not; else r's reason (when
// r is not ok) says how that route ended.
void AdoptTimeShooting(RefineResult& r, RefineResult other) {
  auto outcome = [](const RefineResult& f) {
    return fmt::format("{}: {} on {} samples{}{}", f.route.empty() ? "the detected labels' routes" : f.route,
                       ToString(f.status), f.samples_used, f.reason.empty() ? "" : " (", f.reason.empty() ? "" : f.reason + ")");
  };
  std::vector<std::string> tried = {outcome(r), outcome(other)};
  // Over more samples than an ok fit on cut spans, a fit at the same optimum has smaller standard
  // errors of θ; larger ones say it is not (a ball chattering to rest fit through its last bounces).
  const auto shared = static_cast<Eigen::Index>(r.unknowns.shared());
  const bool more_informative =
      !r.ok() || (other.standard_errors.size() >= shared && r.standard_errors.size() >= shared &&
                  (other.standard_errors.head(shared).array() <= r.standard_errors.head(shared).array()).all());
  if ((other.ok() && (!r.ok() || other.samples_used > r.samples_used) && more_informative) ||
      (other.reported && !r.reported) ||
      (!r.reported && !other.reported && Determines(other) && !Determines(r))) {
    other.start = r.start;
    other.mode_search = r.mode_search;
    if (!r.ok() && !r.reason.empty() && !other.ok()) other.reason += "; the detected labels' fit: " + r.reason;
    r = std::move(other);
  } else if (!r.ok()) {
    r.reason += fmt::format("; {}: {}: {}", other.route, ToString(other.status), other.reason);
  }
  r.routes_tried = std::move(tried);
}


// The routes of the detected labels (RefineRoute, all but kTimeShooting) that follow kLabels, each
// tried after the fit r so far by its own rule and its fit adopted by its own rule. *first_used: the
// samples of the first fit, before the retries cut its spans.
struct LabelledRoutes {
  const Model& model;
  const std::vector<RefineChain>& chains;
  const FitStart& recursive;
  const RefineOptions& options;
  long first_used = 0;

  void Labels(RefineResult& r) { r = FitWithRetries(model, chains, recursive, options, &first_used); }
  // Not ok (other than for too few samples), or ok only on spans the retries cut.
  void RepairedStart(RefineResult& r) {
    FitStart repaired;
    std::string summary;
    if (MayBetter(r, first_used, options) && model.input_size() == 0 &&
        RepairChains(model, chains, recursive, options, &repaired, &summary)) {
      AdoptRepaired(r, FitWithRetries(model, chains, repaired, options, &first_used), summary);
    }
  }
  // (The settled labels follow the grown fit's own jumps only when nothing is ok yet: from the small
  // late impacts' true jumps, ok on a cut span, such a fit became ok on all samples 6 CRLB sd off.)
  void GrownSpan(RefineResult& r) {
    if (MayBetter(r, first_used, options))
      AdoptRoute(r, GrowSpan(model, chains, recursive, options, !r.ok()), RefineRoute::kGrownSpan);
  }
  // Not for a fit ok on cut spans: from the small late impacts' true jumps, two such fits became ok
  // on all samples and 7 and 16 CRLB sd off.
  void SegmentShooting(RefineResult& r) {
    if (options.x0_known.empty() && !r.ok() && MayBetter(r, first_used, options))
      AdoptRoute(r, FitShooting(model, chains, recursive, options), RefineRoute::kSegmentShooting);
  }
};

// The refinement from one initial mode per chain along the labelled routes, in RefineOptions::routes'
// order.
RefineResult RefineFromModes(const Model& model, const std::vector<RefineChain>& chains, const Vec& alpha0,
                             const Vec& beta0, const RefineOptions& given) {
  RefineOptions options = given;
  if (IsAutomaton(model.spec())) {  // the repairs regress one jump map and cut labels without maps
    std::erase_if(options.routes, [](RefineRoute route) {
      return route == RefineRoute::kRepairedStart || route == RefineRoute::kGrownSpan ||
             route == RefineRoute::kSegmentShooting;
    });
    for (const RefineChain& c : chains) options.mend_detections = options.mend_detections && c.maps.empty();
  }
  const FitStart recursive = RecursiveStart(model, chains, alpha0, beta0);
  RefineResult r;
  r.unknowns = Unknowns::Of(model);
  r.names = r.unknowns.Names(model);
  r.start = r.refined = r.estimate = recursive.start;
  if (const std::string bad = FirstNonFinite(chains); !bad.empty()) {
    Fail(r, RefineStatus::kNonFiniteData, "the data are not finite: " + bad);
    return r;
  }
  if (!alpha0.allFinite() || !beta0.allFinite()) {
    Fail(r, RefineStatus::kStartFailed, "the recursive estimate is not finite");
    return r;
  }
  LabelledRoutes routes{model, chains, recursive, options};
  for (RefineRoute route : options.routes) {
    switch (route) {
      case RefineRoute::kLabels: routes.Labels(r); break;
      case RefineRoute::kRepairedStart: routes.RepairedStart(r); break;
      case RefineRoute::kGrownSpan: routes.GrownSpan(r); break;
      case RefineRoute::kSegmentShooting: routes.SegmentShooting(r); break;
      case RefineRoute::kTimeShooting: break;  // once, after the best initial mode's fit (Refine)
    }
  }
  if (r.ok() && r.route.empty())
    r.route = ToString(r.start_repair.empty() ? RefineRoute::kLabels : RefineRoute::kRepairedStart);
  r.reported = r.ok();
  if (r.reported) {
    r.estimate = r.refined;
  } else {
    r.covariance.resize(0, 0);
    r.chain_covariance.clear();
    r.standard_errors.resize(0);
  }
  return r;
}

// The labelled routes from one initial mode per chain, each candidate mode in turn where a chain's is
// unknown (the best fit kept).
RefineResult RefineLabelled(const Model& model, const std::vector<RefineChain>& chains, const Vec& alpha0,
                            const Vec& beta0, const RefineOptions& options) {
  const ModelSpec& spec = model.spec();
  const bool unknown = std::any_of(chains.begin(), chains.end(), [](const RefineChain& c) { return c.initial_mode < 0; });
  if (ModeCount(spec) == 1 || !unknown) {
    RefineResult r = RefineFromModes(model, chains, alpha0, beta0, options);
    r.initial_mode = chains.empty() || chains.front().initial_mode < 0 ? spec.default_mode : chains.front().initial_mode;
    return r;
  }
  RefineResult best;
  std::vector<std::string> tried;
  for (int q = 0; q < ModeCount(spec); ++q) {
    std::vector<RefineChain> candidate = chains;
    for (RefineChain& c : candidate) c.initial_mode = c.initial_mode < 0 ? q : c.initial_mode;
    RefineResult r = RefineFromModes(model, candidate, alpha0, beta0, options);
    tried.push_back(fmt::format("{}: {}", spec.modes[std::size_t(q)],
                                r.ok() ? fmt::format("cost {:.6g}", r.final_cost) : ToString(r.status)));
    r.initial_mode = q;
    for (HybridParameters* p : {&r.start, &r.refined, &r.estimate}) p->initial_mode = q;
    if (q == 0 || Better(r, best)) best = std::move(r);
  }
  best.mode_search = fmt::format("{}", fmt::join(tried, "; "));
  return best;
}

}  // namespace

RefineResult Refine(const Model& model, const std::vector<RefineChain>& chains, const Vec& alpha0,
                    const Vec& beta0, const RefineOptions& given) {
  CheckInputs(model, chains, alpha0, beta0, given);
  // Every run of every route (fits, repaired start, local flows) ends at its next CVODE step once
  // the stop flag is raised.
  RefineOptions options = given;
  if (options.sensitivity.sim.stop == nullptr) options.sensitivity.sim.stop = options.stop;
  if (options.sensitivity.sim.cancel == nullptr) options.sensitivity.sim.cancel = options.cancel;
  RefineResult r = RefineLabelled(model, chains, alpha0, beta0, options);
  const bool data_fault = r.status == RefineStatus::kNonFiniteData;
  long samples = 0;
  for (const RefineChain& c : chains) samples += static_cast<long>(c.t.size());
  // Not ok, or ok on spans that leave samples out: multiple shooting by time fits every sample, unless
  // the samples left out hold jumps the sample rate does not resolve by the fitted model's account.
  const bool tries = options.tries(RefineRoute::kTimeShooting) && options.x0_known.empty() &&
                     (!r.ok() || r.samples_used < samples) && !data_fault &&
                     !SingularAtTheNoise(r, samples) && !options.stopped();
  double unresolved_at = 0.0;
  if (tries && ModelJumpsUnresolved(model, chains, r, options, &unresolved_at)) {
    r.routes_tried = {
        fmt::format("{}: ok on {} samples", r.route, r.samples_used),
        fmt::format("{}: not tried: the fitted model's own jumps from t = {:.6g} on the samples left "
                    "out are less than two samples apart",
                    ToString(RefineRoute::kTimeShooting), unresolved_at)};
  } else if (tries) {
    AdoptTimeShooting(r, TimeShootingFromStarts(model, chains, r.start, options, !r.reported,
                                                 r.ok() ? &r.refined : nullptr));
    if (r.reported) r.estimate = r.refined;
  }
  return r;
}

void AssignChainMaps(const std::vector<std::uint8_t>& chain_start, const IdentifyResult& result,
                     std::vector<RefineChain>* chains) {
  if (result.mode.empty()) return;
  std::vector<std::size_t> first;
  for (std::size_t k = 0; k < chain_start.size(); ++k) {
    if (chain_start[k] || k == 0) first.push_back(k);
  }
  if (chain_start.empty()) first.push_back(0);
  if (first.size() != chains->size()) return;
  for (std::size_t c = 0; c < chains->size(); ++c) {
    const auto begin = static_cast<long>(first[c]);
    const long end = c + 1 < first.size() ? static_cast<long>(first[c + 1]) : static_cast<long>(result.mode.size());
    RefineChain& chain = (*chains)[c];
    chain.initial_mode = result.mode[first[c]];
    bool all = true;
    for (const AutomatonEvent& e : result.events) {
      if (e.sample <= begin || e.sample >= end) continue;
      all = all && e.map >= 0;
      chain.maps.push_back(e.map);
    }
    if (!all) chain.maps.clear();
  }
}

RefineResult RefineIdentification(const Model& model, const std::vector<double>& t, const Mat& y,
                                  const std::vector<std::uint8_t>& chain_start,
                                  const IdentifyResult& recursive, const RefineOptions& options,
                                  const Mat& u) {
  std::vector<RefineChain> chains = SplitChains(t, y, chain_start, recursive.gamma, u);
  AssignChainMaps(chain_start, recursive, &chains);
  return Refine(model, chains, recursive.alpha_hat, recursive.beta_hat, options);
}

}  // namespace hysid
