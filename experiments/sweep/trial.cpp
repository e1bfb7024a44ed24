#include "experiments/sweep/trial.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <functional>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

#include "core/identify/identifier.hpp"
#include "core/identify/lockstep.hpp"
#include "core/identify/metrics.hpp"
#include "core/identify/reconstruct.hpp"
#include "core/model/automaton.hpp"
#include "core/model_file/input_defaults.hpp"
#include "core/sets/set_metrics.hpp"
#include "sim/exogenous.hpp"
#include "sim/events/fitted_events.hpp"
#include "sim/refine/refine.hpp"

namespace hysid {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The parameter lists of θ's blocks: α, β and the guard parameters γ.
enum class Block { kAlpha, kBeta, kGamma };
const std::vector<Parameter>& Params(const Model& m, Block b) {
  return b == Block::kAlpha ? m.spec().alpha : b == Block::kBeta ? m.spec().beta : m.spec().guard_params;
}

// Names of the unknown entries of α (or β, or γ) over all models, in first-seen order.
std::vector<std::string> UnknownNames(const std::vector<Model>& models, Block block) {
  std::vector<std::string> names;
  for (const Model& m : models) {
    for (const std::string& name : hysid::UnknownNames(Params(m, block))) {
      if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
    }
  }
  return names;
}

// Whether some model has an unknown guard parameter (then the γ columns are added).
bool AnyUnknownGamma(const std::vector<Model>& models) { return !UnknownNames(models, Block::kGamma).empty(); }

int MaxStates(const std::vector<Model>& models) {
  int n = 0;
  for (const Model& m : models) n = std::max(n, m.state_size());
  return n;
}

// No commas or line breaks in a free-text cell.
std::string Clean(std::string s) {
  for (char& ch : s) {
    if (ch == ',' || ch == '\n' || ch == '\r' || ch == '"') ch = ';';
  }
  return s;
}

}  // namespace

Crlb UnitCrlb(const Model& model, const Vec& x0, double dt, double t_end, const InputSignal* inputs) {
  try {
    const std::vector<int> measured = MeasuredIndices(model);  // the bound of the measured states
    const bool all = static_cast<int>(measured.size()) == model.state_size();
    return ComputeCrlb(model, x0, SampleGrid{t_end, dt}, Vec::Constant(static_cast<Eigen::Index>(measured.size()), 1.0),
                       Unknowns::Of(model), {}, all ? std::vector<int>{} : measured,
                       inputs != nullptr && !inputs->empty() ? inputs : nullptr);
  } catch (const std::exception& e) {
    Crlb c;
    c.status = CrlbStatus::kSimulationFailed;
    c.message = e.what();
    return c;
  }
}

InputSignal DefaultInputs(const Model& model, double dt, double t_end) {
  InputSignal s;
  if (model.input_size() == 0) return s;
  const SampleGrid grid{t_end, dt};
  for (long k = 0; k < grid.size(); ++k) s.times.push_back(static_cast<double>(k) * dt);
  s.values = EvaluateInputDefaults(model.spec(), s.times);
  return s;
}

std::string FormatNumber(double v) { return std::isnan(v) ? std::string() : fmt::format("{}", v); }

const std::vector<std::string>& SummaryMetrics() {
  static const std::vector<std::string> metrics{
      "misclassification", "precision", "recall",    "fp",       "fn",
      "e_alpha",           "e_beta",    "rel_alpha", "rel_beta", "jump_hausdorff",
      "flow_outside_share"};
  return metrics;
}

namespace {

// Everything one row of trials.csv shows.
struct TrialOutcome {
  const SweepConfig* config = nullptr;
  const Model* model = nullptr;
  const SweepCell* cell = nullptr;
  long unit = 0, trial = 0;
  Vec x0;
  const Crlb* crlb = nullptr;  // the group's bound at σ = 1 (grid.refine only)
  std::string status = kTrialOk, message;
  long samples = 0, jumps_true = 0, jumps_detected = -1;
  Confusion conf;
  ParameterErrors err{kNaN, kNaN, kNaN, kNaN};
  std::string flow_status, jump_status, refine_status;
  SetMetrics sets;
  long flow_vertices = -1, jump_vertices = -1;
  Vec alpha_hat, beta_hat;
  // A hybrid automaton: the true events against the detected ones, the largest event-time error in
  // samples, per map of spec.jumps ‖β̂ − β‖ over its unknown entries and its CRLB-implied mean error
  // at σ = 1 (NaN where the map has no unknown β).
  EventComparison events;
  double event_time_error = kNaN;
  // refine = ml: the fitted model's guard crossings (sim/events) and the largest |t̂ − t| of the true
  // events against the nearest of them (same map) in samples; NaN when the refinement is not ok.
  std::vector<TrueEvent> fitted_events;
  double event_time_error_fitted = kNaN;
  std::vector<double> e_beta_map, crlb_e_beta_map;
  Vec gamma_hat;         // refine = ml: the refined γ (empty otherwise: the recursive pass has none)
  double e_gamma = kNaN;  // ‖γ̂ − γ‖ over the unknown entries (refine = ml)
  // refine = ml and the refinement ok: the standard errors of α̂, β̂, γ̂ (full vectors, NaN for a
  // known entry); empty otherwise.
  Vec se_alpha, se_beta, se_gamma;
  // grid.refine, σ > 0: the CRLB-implied mean errors of α, β, γ at σ over the samples the estimate
  // used (refine = ml: the refinement's samples_used, a prefix of the record; none: every sample);
  // NaN without a bound.
  std::array<double, 3> crlb_fit{kNaN, kNaN, kNaN};
  long samples_used = -1;  // grid.refine: the samples the estimate used (−1: no estimate)
  bool have_estimates = false;
  bool ok() const { return status == kTrialOk; }
};

// One column of trials.csv: its name and how a row's cell is computed.
struct TrialColumn {
  std::string name;
  std::function<std::string(const TrialOutcome&)> cell;
};

std::string Integer(long v) { return fmt::format("{}", v); }
// Metrics: empty unless the row's status is ok.
TrialColumn Metric(std::string name, double (*get)(const TrialOutcome&)) {
  return {std::move(name),
          [get](const TrialOutcome& o) { return o.ok() ? FormatNumber(get(o)) : std::string(); }};
}
// The detector's counts and rates: kept where the fit is not ok only because its estimate contradicts
// the data (kTrialInconsistent), since what the detector found is a fact of the trial.
bool DetectionKnown(const TrialOutcome& o) { return o.ok() || o.status == kTrialInconsistent; }
TrialColumn DetectionCount(std::string name, long (*get)(const TrialOutcome&)) {
  return {std::move(name),
          [get](const TrialOutcome& o) { return DetectionKnown(o) ? Integer(get(o)) : std::string(); }};
}
TrialColumn DetectionMetric(std::string name, double (*get)(const TrialOutcome&)) {
  return {std::move(name),
          [get](const TrialOutcome& o) { return DetectionKnown(o) ? FormatNumber(get(o)) : std::string(); }};
}

// The columns that identify the unit and its cell: unit, cell, trial, model, dt, sigma, the option axes,
// estimator, detector, x0_1..x0_n.
void KeyColumns(const SweepConfig& config, int states, std::vector<TrialColumn>* cols) {
  cols->push_back({"unit", [](const TrialOutcome& o) { return Integer(o.unit); }});
  cols->push_back({"cell", [](const TrialOutcome& o) { return Integer(o.cell->index); }});
  cols->push_back({"trial", [](const TrialOutcome& o) { return Integer(o.trial); }});
  cols->push_back({"model", [](const TrialOutcome& o) {
                     return o.config->models[static_cast<std::size_t>(o.cell->model)].name;
                   }});
  cols->push_back({"dt", [](const TrialOutcome& o) { return FormatNumber(o.cell->dt); }});
  cols->push_back({"sigma", [](const TrialOutcome& o) { return FormatNumber(o.cell->sigma); }});
  for (std::size_t i = 0; i < config.grid.options.size(); ++i) {
    cols->push_back({config.grid.options[i].name,
                     [i](const TrialOutcome& o) { return FormatNumber(o.cell->options[i]); }});
  }
  cols->push_back(
      {"estimator", [](const TrialOutcome& o) { return std::string(ToString(o.cell->estimator)); }});
  cols->push_back({"detector", [](const TrialOutcome& o) {
                     return o.config->oracle ? std::string("oracle")
                                             : std::string(ToString(o.cell->detector));
                   }});
  if (config.grid.refine_axis)
    cols->push_back({"refine", [](const TrialOutcome& o) { return o.cell->refine; }});
  for (int i = 0; i < states; ++i) {
    cols->push_back({fmt::format("x0_{}", i + 1), [i](const TrialOutcome& o) {
                       return i < o.x0.size() ? FormatNumber(o.x0[i]) : std::string();
                     }});
  }
}

// Status, counts, the classification and parameter metrics, the estimators' status and the sets.
void OutcomeColumns(std::vector<TrialColumn>* cols) {
  using O = TrialOutcome;
  cols->push_back({"status", [](const O& o) { return o.status; }});
  cols->push_back({"message", [](const O& o) { return Clean(o.message); }});
  cols->push_back({"samples", [](const O& o) { return Integer(o.samples); }});
  cols->push_back({"jumps_true", [](const O& o) { return Integer(o.jumps_true); }});
  cols->push_back(DetectionCount("jumps_detected", [](const O& o) { return o.jumps_detected; }));
  cols->push_back(DetectionCount("tp", [](const O& o) { return o.conf.tp; }));
  cols->push_back(DetectionCount("fp", [](const O& o) { return o.conf.fp; }));
  cols->push_back(DetectionCount("fn", [](const O& o) { return o.conf.fn; }));
  cols->push_back(DetectionCount("tn", [](const O& o) { return o.conf.tn; }));
  cols->push_back(DetectionMetric("misclassification", [](const O& o) { return o.conf.misclassification(); }));
  cols->push_back(DetectionMetric("precision", [](const O& o) { return o.conf.precision(); }));
  cols->push_back(DetectionMetric("recall", [](const O& o) { return o.conf.recall(); }));
  cols->push_back(Metric("e_alpha", [](const O& o) { return o.err.e_alpha; }));
  cols->push_back(Metric("e_beta", [](const O& o) { return o.err.e_beta; }));
  cols->push_back(Metric("rel_alpha", [](const O& o) { return o.err.rel_alpha; }));
  cols->push_back(Metric("rel_beta", [](const O& o) { return o.err.rel_beta; }));
  cols->push_back({"flow_status", [](const O& o) { return o.flow_status; }});
  cols->push_back({"jump_status", [](const O& o) { return o.jump_status; }});
  cols->push_back(Metric("jump_hausdorff", [](const O& o) { return o.sets.jump_hausdorff; }));
  cols->push_back(Metric("flow_outside_share", [](const O& o) { return o.sets.flow_outside_share; }));
  cols->push_back({"flow_hull_vertices", [](const O& o) {
                     return o.ok() && o.flow_vertices >= 0 ? Integer(o.flow_vertices) : std::string();
                   }});
  cols->push_back({"jump_hull_vertices", [](const O& o) {
                     return o.ok() && o.jump_vertices >= 0 ? Integer(o.jump_vertices) : std::string();
                   }});
}

const Vec& Estimate(const TrialOutcome& o, Block b) {
  return b == Block::kAlpha ? o.alpha_hat : b == Block::kBeta ? o.beta_hat : o.gamma_hat;
}

// α̂, β̂ (and γ̂ when a model has unknown guard parameters) of each unknown parameter name over the
// models (empty where the row's model has none).
void EstimateColumns(const std::vector<Model>& models, std::vector<TrialColumn>* cols) {
  for (Block block : {Block::kAlpha, Block::kBeta, Block::kGamma}) {
    const char* prefix = block == Block::kAlpha ? "alpha_hat_" : block == Block::kBeta ? "beta_hat_" : "gamma_hat_";
    for (const std::string& name : UnknownNames(models, block)) {
      cols->push_back({prefix + name, [block, name](const TrialOutcome& o) {
                         const auto& params = Params(*o.model, block);
                         const Vec& hat = Estimate(o, block);
                         std::string text;
                         for (std::size_t i = 0; i < params.size(); ++i) {
                           const auto ii = static_cast<Eigen::Index>(i);
                           if (params[i].name == name && !params[i].known && o.have_estimates && ii < hat.size()) {
                             text = FormatNumber(hat[ii]);
                           }
                         }
                         return text;
                       }});
    }
  }
}

// rel_err_NAME of each unknown parameter name over the models: |θ̂ − θ| / |θ| against the row's model's
// true value θ, or |θ̂ − θ| where θ = 0.
// (Guard parameter names never clash: a model's parameter names are distinct.)
void RelativeErrorColumns(const std::vector<Model>& models, std::vector<TrialColumn>* cols) {
  const std::vector<std::string> alpha_names = UnknownNames(models, Block::kAlpha);
  for (Block block : {Block::kAlpha, Block::kBeta, Block::kGamma}) {
    for (const std::string& name : UnknownNames(models, block)) {
      const bool clash = block == Block::kBeta &&
                         std::find(alpha_names.begin(), alpha_names.end(), name) != alpha_names.end();
      cols->push_back({kRelativeErrorPrefix + std::string(clash ? "beta_" : "") + name,
                       [block, name](const TrialOutcome& o) {
                         const auto& params = Params(*o.model, block);
                         const Vec& hat = Estimate(o, block);
                         std::string text;
                         for (std::size_t i = 0; i < params.size(); ++i) {
                           if (params[i].name != name || params[i].known || !o.ok()) continue;
                           if (static_cast<Eigen::Index>(i) >= hat.size()) continue;
                           const double truth = params[i].value;
                           const double err = std::abs(hat[static_cast<Eigen::Index>(i)] - truth);
                           text = FormatNumber(truth != 0 ? err / std::abs(truth) : err);
                         }
                         return text;
                       }});
    }
  }
}

const Vec& StandardErrors(const TrialOutcome& o, Block b) {
  return b == Block::kAlpha ? o.se_alpha : b == Block::kBeta ? o.se_beta : o.se_gamma;
}

// The z of a two-sided 95 % normal interval: the reported interval of θ_i is θ̂_i ± kZ95·se_i.
constexpr double kZ95 = 1.959963984540054;

// The se_NAME (cover = false) or cover_NAME cell of parameter `name` of `block` (see UncertaintyColumns).
std::string UncertaintyCell(const TrialOutcome& o, Block block, const std::string& name, bool cover) {
  const auto& params = Params(*o.model, block);
  const Vec& hat = Estimate(o, block);
  const Vec& se = StandardErrors(o, block);
  std::string text;
  for (std::size_t i = 0; i < params.size(); ++i) {
    const auto ii = static_cast<Eigen::Index>(i);
    if (params[i].name != name || params[i].known || !o.ok() || ii >= se.size()) continue;
    if (std::isnan(se[ii])) continue;
    const bool in = std::abs(hat[ii] - params[i].value) <= kZ95 * se[ii];
    text = cover ? Integer(in ? 1 : 0) : FormatNumber(se[ii]);
  }
  return text;
}

// grid.refine: se_NAME (the refinement's standard error of each unknown parameter, empty where the
// refinement did not run or is not ok) and cover_NAME (1 when the truth lies in θ̂ ± 1.96·se, else 0;
// empty without a standard error), named as the rel_err_* columns (se_beta_NAME, cover_beta_NAME for
// a β name that is also an α name).
void UncertaintyColumns(const std::vector<Model>& models, std::vector<TrialColumn>* cols) {
  const std::vector<std::string> alpha_names = UnknownNames(models, Block::kAlpha);
  for (const bool cover : {false, true}) {
    for (Block block : {Block::kAlpha, Block::kBeta, Block::kGamma}) {
      for (const std::string& name : UnknownNames(models, block)) {
        const bool clash = block == Block::kBeta &&
                           std::find(alpha_names.begin(), alpha_names.end(), name) != alpha_names.end();
        cols->push_back({(cover ? kCoveragePrefix : "se_") + std::string(clash ? "beta_" : "") + name,
                         [block, name, cover](const TrialOutcome& o) {
                           return UncertaintyCell(o, block, name, cover);
                         }});
      }
    }
  }
}

// grid.refine: the refinement's status and the cell's CRLB-implied mean errors (the σ = 1 bound scaled
// by σ; empty for σ = 0 or without a bound).
// With unknown guard parameters also e_gamma (‖γ̂ − γ‖ of the refined estimate) and crlb_e_gamma.
void RefineColumns(bool gamma, std::vector<TrialColumn>* cols) {
  using O = TrialOutcome;
  const auto bound = [](const O& o, double Crlb::*mean) {
    const bool have = o.crlb != nullptr && o.crlb->ok() && o.cell->sigma > 0;
    return have ? FormatNumber(o.cell->sigma * (*o.crlb).*mean) : std::string();
  };
  cols->push_back({"refine_status", [](const O& o) { return o.refine_status; }});
  cols->push_back({"crlb_e_alpha", [bound](const O& o) { return bound(o, &Crlb::mean_e_alpha); }});
  cols->push_back({"crlb_e_beta", [bound](const O& o) { return bound(o, &Crlb::mean_e_beta); }});
  // The bound over the samples the estimate used (empty where the row is not ok).
  const auto fit = [](const O& o, int i) {
    return o.ok() ? FormatNumber(o.crlb_fit[static_cast<std::size_t>(i)]) : std::string();
  };
  cols->push_back({"samples_used", [](const O& o) {
                     return o.samples_used >= 0 && o.have_estimates ? Integer(o.samples_used) : std::string();
                   }});
  cols->push_back({"crlb_fit_e_alpha", [fit](const O& o) { return fit(o, 0); }});
  cols->push_back({"crlb_fit_e_beta", [fit](const O& o) { return fit(o, 1); }});
  if (!gamma) return;
  cols->push_back(Metric("e_gamma", [](const O& o) { return o.e_gamma; }));
  cols->push_back({"crlb_e_gamma", [bound](const O& o) { return bound(o, &Crlb::mean_e_gamma); }});
  cols->push_back({"crlb_fit_e_gamma", [fit](const O& o) { return fit(o, 2); }});
}

// The names of the jump maps with unknown β over the automaton models, in first-seen order.
std::vector<std::string> MapsWithUnknownBeta(const std::vector<Model>& models) {
  std::vector<std::string> names;
  for (const Model& m : models) {
    for (const JumpMap& map : m.spec().jumps) {
      bool unknown = false;
      for (int b = map.beta_first; b < map.beta_first + map.beta_count; ++b) {
        unknown = unknown || !m.spec().beta[static_cast<std::size_t>(b)].known;
      }
      if (unknown && std::find(names.begin(), names.end(), map.name) == names.end()) names.push_back(map.name);
    }
  }
  return names;
}

bool AnyAutomaton(const std::vector<Model>& models) {
  return std::any_of(models.begin(), models.end(), [](const Model& m) { return IsAutomaton(m.spec()); });
}

// The value of map `name` of the row's model in `per_map` (one per spec.jumps entry), or NaN.
double OfMap(const TrialOutcome& o, const std::string& name, const std::vector<double>& per_map) {
  const auto& jumps = o.model->spec().jumps;
  for (std::size_t m = 0; m < jumps.size() && m < per_map.size(); ++m) {
    if (jumps[m].name == name) return per_map[m];
  }
  return kNaN;
}

// Sweeps of hybrid automata: the events (true; assigned to the right map; matched to another map's
// event; missed; spurious), the largest event-time error in samples (of the detected events and, with
// grid.refine, of the fitted model's guard crossings), e_beta_MAP per map with unknown
// β and, with grid.refine, crlb_e_beta_MAP (σ times the σ = 1 bound; empty for σ = 0).
void AutomatonColumns(const SweepConfig& config, const std::vector<Model>& models, std::vector<TrialColumn>* cols) {
  using O = TrialOutcome;
  // The recursive pass' events: also in a row whose refinement failed (not in summary.csv).
  const auto events = [](std::string name, long (*get)(const O&)) {
    return TrialColumn{std::move(name),
                       [get](const O& o) { return o.events.counts.empty() ? std::string() : Integer(get(o)); }};
  };
  cols->push_back(events("events_true", [](const O& o) { return o.events.true_events; }));
  cols->push_back(events("events_right", [](const O& o) { return o.events.right; }));
  cols->push_back(events("events_wrong_map", [](const O& o) { return o.events.wrong_map(); }));
  cols->push_back(events("events_missed", [](const O& o) { return o.events.missed; }));
  cols->push_back(events("events_spurious", [](const O& o) { return o.events.spurious; }));
  cols->push_back({"event_time_error", [](const O& o) {
                     return o.events.counts.empty() ? std::string() : FormatNumber(o.event_time_error);
                   }});
  if (config.grid.refine_axis) {
    cols->push_back({"event_time_error_fitted", [](const O& o) {
                       return o.ok() && o.cell->refine == "ml" ? FormatNumber(o.event_time_error_fitted)
                                                               : std::string();
                     }});
  }
  for (const std::string& map : MapsWithUnknownBeta(models)) {
    cols->push_back({"e_beta_" + map, [map](const O& o) {
                       return o.ok() ? FormatNumber(OfMap(o, map, o.e_beta_map)) : std::string();
                     }});
    if (!config.grid.refine_axis) continue;
    cols->push_back({"crlb_e_beta_" + map, [map](const O& o) {
                       return o.cell->sigma > 0 ? FormatNumber(o.cell->sigma * OfMap(o, map, o.crlb_e_beta_map))
                                                : std::string();
                     }});
  }
}

std::vector<TrialColumn> TrialColumns(const SweepConfig& config, const std::vector<Model>& models) {
  std::vector<TrialColumn> cols;
  KeyColumns(config, MaxStates(models), &cols);
  OutcomeColumns(&cols);
  if (config.grid.refine_axis) RefineColumns(AnyUnknownGamma(models), &cols);
  if (AnyAutomaton(models)) AutomatonColumns(config, models, &cols);
  EstimateColumns(models, &cols);
  RelativeErrorColumns(models, &cols);
  if (config.grid.refine_axis) UncertaintyColumns(models, &cols);
  return cols;
}

// The settings of the unit's cell.
IdentifierSettings CellSettings(const SweepConfig& config, const Model& model, const SweepCell& cell) {
  IdentifierSettings s = config.identifier;
  cell.Apply(config.grid, &s);
  if (config.known_sigma) s.sigma = Vec::Constant(model.state_size(), cell.sigma);
  // The trajectories come from CVODE at these tolerances: the data's accuracy apart from σ.
  s.data_rtol = config.simulator.rtol;
  s.data_atol = config.simulator.atol;
  return s;
}

// γ(t) = [j(t) ≠ j(t − δt)]: the true jump labels.
std::vector<std::uint8_t> TrueLabels(const Trajectory& truth) {
  std::vector<std::uint8_t> labels(truth.j.size(), 0);
  for (std::size_t k = 1; k < truth.j.size(); ++k) labels[k] = truth.j[k] != truth.j[k - 1] ? 1 : 0;
  return labels;
}

// The true events of a run: each jump record at the first sample whose jump count includes it.
std::vector<TrueEvent> TrueEvents(const Trajectory& truth) {
  std::vector<TrueEvent> out;
  std::size_t k = 0;
  for (const JumpRecord& r : truth.jumps) {
    while (k < truth.j.size() && truth.j[k] < r.j) ++k;
    if (k == 0 || k >= truth.j.size()) continue;  // before the first sample or after the last
    out.push_back({static_cast<long>(k), r.t, r.map});
  }
  return out;
}

// A hybrid automaton's metrics: the events against the truth and ‖β̂ − β‖ per jump map.
void CompareAutomaton(const Trajectory& truth, const IdentifyResult& res, TrialOutcome* o) {
  const ModelSpec& spec = o->model->spec();
  o->events = CompareEvents(static_cast<int>(JumpMaps(spec).size()), TrueEvents(truth), res.events);
  const bool matched = o->events.true_events > o->events.missed;
  o->event_time_error = matched ? o->events.max_time_error / truth.dt : kNaN;
  if (o->refine_status == ToString(RefineStatus::kOk)) {
    o->event_time_error_fitted = LargestNearestTimeError(TrueEvents(truth), o->fitted_events) / truth.dt;
  }
  for (const JumpMap& map : spec.jumps) {
    double sum = 0.0;
    bool unknown = false;
    for (int b = map.beta_first; b < map.beta_first + map.beta_count; ++b) {
      if (spec.beta[static_cast<std::size_t>(b)].known) continue;
      unknown = true;
      sum += std::pow(o->beta_hat[b] - spec.beta[static_cast<std::size_t>(b)].value, 2);
    }
    o->e_beta_map.push_back(unknown ? std::sqrt(sum) : kNaN);
  }
}

// What the identifier of a unit is given: its settings, options and samples (the noisy samples,
// or the states reconstructed from the measured ones).
struct UnitInput {
  IdentifierSettings settings;
  IdentifyOptions options;
  std::vector<int> measured;
  bool partial = false;
  Reconstruction rec;
  const Mat* noisy = nullptr;  // the noisy samples (σ = 0: the truth)
  const Mat& y() const { return partial ? rec.x : *noisy; }
};

// The unit's input to the identifier.
// The noisy samples are y = x + σ·E with the trial's standard normals E, shared by every cell of the
// group (common random numbers); with them the flow rows, shared by the units of one σ.
void PrepareUnit(const SweepConfig& config, const TrialInputs& in, const TrialOutcome& o, UnitInput* u) {
  const Model& model = *o.model;
  const SweepCell& cell = *o.cell;
  const Trajectory& truth = *in.truth;
  u->settings = CellSettings(config, model, cell);
  if (cell.sigma > 0) {
    if (in.normals == nullptr || in.normals->cols() != truth.x.cols() || in.noisy == nullptr) {
      throw std::logic_error("RunTrial: σ > 0 without the trial's standard normals");
    }
    if (in.noisy->sigma != cell.sigma || in.noisy->y.cols() != truth.x.cols()) {
      in.noisy->y.noalias() = truth.x + cell.sigma * *in.normals;  // x(i, k) + σ·E(i, k)
      in.noisy->sigma = cell.sigma;
    }
  }
  IdentifyOptions& options = u->options;
  options.statistics = false;
  options.check_paper_bound = false;  // every detection is counted against the true jumps
  options.stop = in.stop;             // a stopped trial's row is dropped by the runner
  if (config.oracle) options.labels = TrueLabels(truth);
  if (in.inputs != nullptr) options.inputs = in.inputs->values.leftCols(truth.x.cols());
  u->measured = MeasuredIndices(model);
  u->partial = static_cast<int>(u->measured.size()) < model.state_size();
  const Mat& noisy = cell.sigma > 0 ? in.noisy->y : truth.x;
  // Only some states measured: the others reconstructed from them as the identifier's start, the
  // detected kinks as its labels (core/identify/reconstruct.hpp), as `hysid identify` does.
  if (u->partial) {
    ReconstructOptions ro;
    ro.stop = in.stop;
    u->rec = ReconstructStates(PlanReconstruction(model, u->measured), truth.t, noisy(u->measured, Eigen::all), {},
                               Vec(), ro);
    if (!config.oracle) options.labels = u->rec.gamma;
  }
  u->noisy = &noisy;
  if (!u->partial && in.noisy != nullptr && options.labels.empty() && !IsAutomaton(model.spec()) &&
      model.input_size() == 0) {
    if (in.noisy->rows_sigma != cell.sigma) {  // the group's model; y changes with σ only
      in.noisy->rows = BuildFlowRows(model, u->y(), truth.dt);
      in.noisy->rows_sigma = cell.sigma;
    }
    options.flow_rows = &in.noisy->rows;
  }
}

// The refinement's standard errors as full α, β, γ vectors (NaN for a known entry); empty when not ok.
void KeepStandardErrors(const Model& model, const RefineResult& rr, TrialOutcome* o) {
  if (!rr.ok() || rr.standard_errors.size() < rr.unknowns.shared()) return;
  o->se_alpha = Vec::Constant(model.alpha().size(), kNaN);
  o->se_beta = Vec::Constant(model.beta().size(), kNaN);
  o->se_gamma = Vec::Constant(model.gamma().size(), kNaN);
  Eigen::Index k = 0;
  for (int i : rr.unknowns.alpha) o->se_alpha[i] = rr.standard_errors[k++];
  for (int i : rr.unknowns.beta) o->se_beta[i] = rr.standard_errors[k++];
  for (int i : rr.unknowns.gamma) o->se_gamma[i] = rr.standard_errors[k++];
}

// crlb_fit: the group's bound (σ = 1) when the estimate used every sample, else the bound over the
// first `used` samples at the truth; scaled by σ. NaN without a bound or for σ = 0.
void FitBound(const TrialInputs& in, long used, TrialOutcome* o) {
  o->samples_used = used;
  const double sigma = o->cell->sigma;
  if (in.crlb == nullptr || !in.crlb->ok() || sigma <= 0 || used < 2) return;
  const Trajectory& truth = *in.truth;
  Crlb cut;
  if (used < truth.size()) {  // the last fitted sample is used − 1: t_end between it and the next
    cut = UnitCrlb(*o->model, *in.x0, truth.dt, (static_cast<double>(used) - 0.5) * truth.dt, in.inputs);
    if (!cut.ok()) return;
  }
  const Crlb& c = used < truth.size() ? cut : *in.crlb;
  o->crlb_fit = {sigma * c.mean_e_alpha, sigma * c.mean_e_beta, sigma * c.mean_e_gamma};
}

// The identification's result `res` of the unit (refined with refine = ml) against the truth.
void Evaluate(const SweepConfig& config, const TrialInputs& in, const UnitInput& u, const IdentifyResult& res,
              TrialOutcome* o) {
  const Model& model = *o->model;
  const SweepCell& cell = *o->cell;
  const Trajectory& truth = *in.truth;
  const IdentifierSettings& s = u.settings;
  const IdentifyOptions& options = u.options;
  const std::vector<int>& measured = u.measured;
  const bool partial = u.partial;
  const Mat& y = u.y();
  o->alpha_hat = res.alpha_hat;
  o->beta_hat = res.beta_hat;
  if (cell.refine == "ml") {
    // The error metrics are the refined estimate's. A fit that is not ok fails the trial (status
    // refine_failed, no metrics; α̂, β̂ are the recursive estimate it kept), so that no cell averages
    // recursive estimates into its refined ones.
    RefineOptions ro;
    ro.stop = in.stop;
    if (partial) ro.measured = measured;
    if (config.known_sigma && cell.sigma > 0) {
      ro.sigma = Vec::Constant(static_cast<Eigen::Index>(measured.size()), cell.sigma);
    }
    const RefineResult rr =
        RefineIdentification(model, truth.t, y, {}, RefinementStart(res), ro, options.inputs);
    if (IsAutomaton(model.spec()) && rr.ok()) {
      const FittedEvents fitted = FitEventTimes(model, truth.t, y, {}, options.inputs, RefinementStart(res), rr);
      for (const FittedCrossing& c : fitted.crossings) o->fitted_events.push_back({0, c.time, c.map});
    }
    o->refine_status = ToString(rr.status);
    KeepStandardErrors(model, rr, o);
    FitBound(in, rr.samples_used, o);
    o->alpha_hat = rr.estimate.alpha;
    o->beta_hat = rr.estimate.beta;
    o->gamma_hat = rr.estimate.gamma;
    if (!rr.unknowns.gamma.empty()) {
      double sum = 0.0;
      for (int i : rr.unknowns.gamma) sum += std::pow(rr.estimate.gamma[i] - model.gamma()[i], 2);
      o->e_gamma = std::sqrt(sum);
    }
    if (!rr.ok()) {
      o->status = kTrialRefineFailed;
      o->message = fmt::format("refinement {}: {}", ToString(rr.status), rr.reason);
    }
  } else if (config.grid.refine_axis) {
    FitBound(in, truth.size(), o);  // the recursive estimate uses every sample
  }
  if (cell.refine != "ml" && res.flow_status == EstimatorStatus::kInconsistent) {
    o->status = kTrialInconsistent;
    o->message = res.flow_reason;
  }
  o->have_estimates = true;
  o->jumps_detected = res.jumps_detected;
  o->flow_status = ToString(res.flow_status);
  o->jump_status = ToString(res.jump_status);
  o->conf = CompareJumps(truth.j, res.gamma);
  if (o->ok() && (!o->alpha_hat.allFinite() || !o->beta_hat.allFinite())) {
    o->status = "non_finite_estimate";
    o->message = "an estimate is not finite";
    return;
  }
  o->err = CompareParameters(model, o->alpha_hat, o->beta_hat);
  if (IsAutomaton(model.spec())) CompareAutomaton(truth, res, o);
  // Not beyond the hull dimension limit; the true sets of a model with inputs depend on u, which a
  // hull vertex does not keep (no set metrics then).
  if (s.sets && res.sets_skipped.empty() && model.input_size() == 0) {
    o->sets = CompareSets(model, res.flow_hull, res.jump_hull);
    o->flow_vertices = static_cast<long>(res.flow_hull.cols());
    o->jump_vertices = static_cast<long>(res.jump_hull.cols());
  }
}

// Whether two cells identify alike: they differ in `refine` at most (unused axes are NaN in both).
bool SameIdentification(const SweepCell& a, const SweepCell& b) {
  const auto same = [](double u, double v) { return u == v || (std::isnan(u) && std::isnan(v)); };
  return a.model == b.model && a.dt == b.dt && a.sigma == b.sigma && a.estimator == b.estimator &&
         a.detector == b.detector &&
         std::equal(a.options.begin(), a.options.end(), b.options.begin(), b.options.end(), same);
}

// The identifier on the unit's samples and the metrics against the truth. The recursive pass of a
// refined cell is its recursive cell's, run just before on the same samples (kept in in.noisy).
void Identify(const SweepConfig& config, const TrialInputs& in, TrialOutcome* o) {
  UnitInput u;
  PrepareUnit(config, in, *o, &u);
  NoisySamples local;  // without the trial's shared buffer: this unit's result only
  NoisySamples* kept = in.noisy != nullptr ? in.noisy : &local;
  if (!kept->identified_cell || !SameIdentification(*kept->identified_cell, *o->cell)) {
    kept->identified = hysid::Identify(*o->model, u.y(), in.truth->dt, u.settings, u.options);
    kept->identified_cell = *o->cell;
  }
  Evaluate(config, in, u, kept->identified, o);
}

}  // namespace

std::vector<std::string> TrialHeader(const SweepConfig& config, const std::vector<Model>& models) {
  std::vector<std::string> header;
  for (const TrialColumn& c : TrialColumns(config, models)) header.push_back(c.name);
  return header;
}

namespace {

// Unit (cell, trial)'s outcome before its identification: its keys, and a failed simulation as its status.
TrialOutcome StartOutcome(const SweepConfig& config, const std::vector<Model>& models, const SweepCell& cell,
                          long unit, long trial, const TrialInputs& in) {
  const Trajectory& truth = *in.truth;
  TrialOutcome o;
  o.config = &config;
  o.model = &models[static_cast<std::size_t>(cell.model)];
  o.cell = &cell;
  o.unit = unit;
  o.trial = trial;
  o.x0 = *in.x0;
  o.crlb = in.crlb;
  if (in.crlb != nullptr && in.crlb->ok() && IsAutomaton(o.model->spec())) {
    o.crlb_e_beta_map = MeanEBetaPerMap(o.model->spec(), Unknowns::Of(*o.model), *in.crlb);
  }
  o.samples = truth.size();
  o.jumps_true = static_cast<long>(truth.jumps.size());
  if (!in.sim_error.empty()) {
    o.status = "error";
    o.message = in.sim_error;
  } else if (!truth.status.completed()) {
    o.status = ToString(truth.status.stop);
    o.message =
        truth.status.stop == SimStop::kZeno
            ? fmt::format("Zeno: jumps accumulate at t = {:.6g} s before t_end = {} s; shorten t_end",
                          truth.status.zeno_time, config.models[static_cast<std::size_t>(cell.model)].t_end)
            : truth.status.message;
  }
  return o;
}

// An exception inside the identifier or the metrics: the row's status.
void Fail(const std::exception& e, TrialOutcome* o) {
  o->status = "error";
  o->message = e.what();
  o->have_estimates = false;
}

std::vector<std::string> RowOf(const SweepConfig& config, const std::vector<Model>& models, const TrialOutcome& o) {
  std::vector<std::string> row;
  for (const TrialColumn& c : TrialColumns(config, models)) row.push_back(c.cell(o));
  return row;
}

// The units' outcomes identified together (IdentifyLockstep); false, with nothing to use, when they
// cannot be: a failed simulation, units on different samples or options, or an exception (then
// each run alone reports its own).
bool IdentifyTogether(const SweepConfig& config, const std::vector<Model>& models,
                      const std::vector<const SweepCell*>& cells, const std::vector<long>& units, long trial,
                      const TrialInputs& in, std::vector<TrialOutcome>* outcomes) {
  for (const SweepCell* c : cells) {
    if (c->sigma != cells.front()->sigma || c->model != cells.front()->model) return false;  // other samples
  }
  std::vector<UnitInput> inputs(units.size());
  std::vector<IdentifierSettings> settings;
  std::vector<std::size_t> result_of(units.size());  // a unit's identification among `settings`
  try {
    for (std::size_t i = 0; i < units.size(); ++i) {
      outcomes->push_back(StartOutcome(config, models, *cells[i], units[i], trial, in));
      if (!outcomes->back().ok()) return false;
      PrepareUnit(config, in, outcomes->back(), &inputs[i]);
      if (inputs[i].options.flow_rows == nullptr) return false;  // not the block path (labels, inputs, …)
      if (i > 0 && SameIdentification(*cells[i - 1], *cells[i])) {
        result_of[i] = result_of[i - 1];  // a refined cell: its recursive cell's identification
        continue;
      }
      result_of[i] = settings.size();
      settings.push_back(inputs[i].settings);
    }
    const TrialOutcome& first = outcomes->front();
    const std::vector<IdentifyResult> results =
        IdentifyLockstep(*first.model, inputs.front().y(), in.truth->dt, settings, inputs.front().options);
    for (std::size_t i = 0; i < units.size(); ++i) {
      try {
        Evaluate(config, in, inputs[i], results[result_of[i]], &(*outcomes)[i]);
      } catch (const std::exception& e) {
        Fail(e, &(*outcomes)[i]);
      }
    }
  } catch (const std::exception&) {
    return false;
  }
  return true;
}

}  // namespace

std::vector<std::string> RunTrial(const SweepConfig& config, const std::vector<Model>& models,
                                  const SweepCell& cell, long unit, long trial, const TrialInputs& in) {
  TrialOutcome o = StartOutcome(config, models, cell, unit, trial, in);
  if (o.ok()) {
    try {
      Identify(config, in, &o);
    } catch (const std::exception& e) {
      Fail(e, &o);
    }
  }
  return RowOf(config, models, o);
}

std::vector<std::vector<std::string>> RunTrials(const SweepConfig& config, const std::vector<Model>& models,
                                                const std::vector<const SweepCell*>& cells,
                                                const std::vector<long>& units, long trial, const TrialInputs& in) {
  std::vector<std::vector<std::string>> rows;
  std::vector<TrialOutcome> outcomes;
  if (units.size() > 1 && IdentifyTogether(config, models, cells, units, trial, in, &outcomes)) {
    for (const TrialOutcome& o : outcomes) rows.push_back(RowOf(config, models, o));
    return rows;
  }
  for (std::size_t i = 0; i < units.size(); ++i) {
    rows.push_back(RunTrial(config, models, *cells[i], units[i], trial, in));
  }
  return rows;
}

}  // namespace hysid
