#include "experiments/request/outcome_json.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/identify/metrics.hpp"
#include "core/model/automaton.hpp"
#include "core/sets/set_metrics.hpp"
#include "experiments/request/events_json.hpp"

namespace hysid {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

std::vector<double> Values(const Vec& v) { return std::vector<double>(v.data(), v.data() + v.size()); }




// The detector's options that it reads, by name: numbers, or the choice's name.
nlohmann::json DetectorOptionsJson(const DetectorSettings& s) {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& o : DetectorOptions()) {
    if (!DescriptorOf(s.kind).Reads(o.name)) continue;
    const std::string key(o.name);
    if (o.type == OptionType::kChoice) {
      out[key] = o.Format(o.get(s));
    } else {
      out[key] = o.get(s);
    }
  }
  return out;
}

namespace {

// Samples left out as outliers: run (from 1), line, t, the state's column, its value, and how far
// off in robust sd (data.outliers: the second difference; fit_outliers: the residual off the fit).
nlohmann::json OutliersJson(const SampleData& data, const std::vector<OutlierSample>& outliers) {
  nlohmann::json out = nlohmann::json::array();
  for (const OutlierSample& o : outliers) {
    out.push_back({{"run", o.run + 1},
                   {"line", o.line},
                   {"t", o.t},
                   {"column", data.state_columns[std::size_t(o.row)]},
                   {"value", o.value},
                   {"sds", o.sds}});
  }
  return out;
}

}  // namespace

nlohmann::json DataJson(const SampleData& data) {
  return {{"path", data.path},
          {"state_columns", data.state_columns},
          {"rows", data.t.size() + data.missing.size() + data.outliers.size()},
          {"samples", data.t.size()},
          {"dt", data.dt},
          {"uniform", data.uniform},
          {"runs", data.run_names},
          {"chains", data.chains()},
          {"max_gap", data.max_gap},
          {"gaps", data.gaps},
          {"missing_rows", data.missing_rows},
          {"first_missing_line", data.first_missing_line},
          {"outliers", OutliersJson(data, data.outliers)}};
}

nlohmann::json SettingsJson(const IdentifierSettings& settings, const std::string& accuracy_source) {
  return {{"estimator", ToString(settings.flow_estimator.kind)},
          {"jump_estimator", ToString(settings.jump_estimator.kind)},
          {"detector", ToString(settings.detector.kind)},
          {"detector_options", DetectorOptionsJson(settings.detector)},
          {"data_rtol", settings.data_rtol},
          {"data_atol", settings.data_atol},
          {"data_accuracy_source", accuracy_source},
          {"localize", settings.localize},
          {"second_pass", settings.second_pass}};
}

// The noise shapes C of gtls/frisch and the σ they come from (null entries when not used).
nlohmann::json NoiseJson(const IdentifyResult& r) {
  nlohmann::json out = {{"sigma", nullptr}, {"sigma_estimated", r.noise_sigma_estimated}};
  if (r.noise_sigma.size()) out["sigma"] = Values(r.noise_sigma);
  out["flow_shape_diagonal"] =
      r.flow_noise_shape.size() ? nlohmann::json(Values(r.flow_noise_shape.diagonal())) : nlohmann::json();
  out["jump_shape_diagonal"] =
      r.jump_noise_shape.size() ? nlohmann::json(Values(r.jump_noise_shape.diagonal())) : nlohmann::json();
  return out;
}

nlohmann::json BoxJson(const Mat& box) {
  if (box.size() == 0) return nullptr;
  nlohmann::json out = nlohmann::json::array();
  for (Eigen::Index i = 0; i < box.rows(); ++i) out.push_back({box(i, 0), box(i, 1)});
  return out;
}

nlohmann::json RecursiveResultJson(const IdentifyResult& r) {
  nlohmann::json out = {{"alpha", Values(r.alpha_hat)},           {"beta", Values(r.beta_hat)},
                        {"flow_box", BoxJson(r.flow_box)},        {"jump_box", BoxJson(r.jump_box)},
                        {"jumps_detected", r.jumps_detected},     {"jumps_localized", r.jumps_localized},
                        {"sets_skipped", r.sets_skipped},         {"flow_hull_vertices", r.flow_hull.cols()},
                        {"flow_hull_volume", r.flow_hull_volume}, {"jump_hull_vertices", r.jump_hull.cols()},
                        {"jump_hull_volume", r.jump_hull_volume}, {"second_pass", nullptr}};
  if (r.second_pass) {
    out["second_pass"] = {
        {"flow_to_jump", r.reclassified_to_jump},
        {"jump_to_flow", r.reclassified_to_flow},
        {"first_pass_jumps", std::count(r.first_pass_gamma.begin(), r.first_pass_gamma.end(), 1)},
        {"first_pass_alpha", Values(r.first_pass_alpha_hat)},
        {"first_pass_beta", Values(r.first_pass_beta_hat)}};
  }
  return out;
}

// Every sample the detector flagged (γ = 1): its index, run, chain, line and time.
nlohmann::json DetectionsJson(const SampleData& data, const IdentifyResult& r,
                              const std::vector<long>& chain) {
  nlohmann::json out = nlohmann::json::array();
  for (std::size_t k = 0; k < r.gamma.size(); ++k) {
    if (!r.gamma[k]) continue;
    out.push_back({{"sample", k},
                   {"run", data.run[k] + 1},
                   {"chain", chain[k]},
                   {"line", data.line[k]},
                   {"t", data.t[k]}});
  }
  return out;
}

// Per chain: where it is, and what the recursive estimators did with it (each sample after the
// chain's first is one flow or one jump update).
nlohmann::json ChainsJson(const SampleData& data, const IdentifyResult& r, const std::vector<long>& chain) {
  nlohmann::json out = nlohmann::json::array();
  for (std::size_t first = 0, end = 0; first < data.t.size(); first = end) {
    for (end = first + 1; end < data.t.size() && !data.chain_start[end];) ++end;
    const long samples = static_cast<long>(end - first);
    const long jumps =
        std::count(r.gamma.begin() + static_cast<long>(first), r.gamma.begin() + static_cast<long>(end), 1);
    out.push_back({{"chain", chain[first]},
                   {"run", data.run[first] + 1},
                   {"first_sample", first},
                   {"first_line", data.line[first]},
                   {"t_first", data.t[first]},
                   {"t_last", data.t[end - 1]},
                   {"samples", samples},
                   {"jumps", jumps},
                   {"flow_updates", samples - 1 - jumps},
                   {"jump_updates", jumps}});
  }
  return out;
}

// Against the data's column j and the model's true values and sets (as PrintTruth).
nlohmann::json TruthJson(const Model& model, const std::vector<int>& j, const IdentifyResult& r) {
  const Confusion c = CompareJumps(j, r.gamma);
  const ParameterErrors e = CompareParameters(model, r.alpha_hat, r.beta_hat);
  nlohmann::json out = {{"true_jumps", c.tp + c.fn},
                        {"tp", c.tp},
                        {"fp", c.fp},
                        {"fn", c.fn},
                        {"tn", c.tn},
                        {"misclassification", c.misclassification()},
                        {"precision", c.precision()},
                        {"recall", c.recall()},
                        {"e_alpha", e.e_alpha},
                        {"e_beta", e.e_beta},
                        {"rel_alpha", e.rel_alpha},
                        {"rel_beta", e.rel_beta},
                        {"sets", nullptr}};
  if (r.sets_skipped.empty() && model.input_size() == 0) {  // C, D of a model with inputs move with u
    const SetMetrics sm = CompareSets(model, r.flow_hull, r.jump_hull);
    out["sets"] = {{"flow_outside_share", sm.flow_outside_share},
                   {"jump_hausdorff",
                    model.has_jump_set_distance() ? nlohmann::json(sm.jump_hausdorff) : nlohmann::json()}};
  }
  return out;
}

// The checks a fit passes to be ok: each check's value and its limits (RefineOptions).
nlohmann::json ChecksJson(const RefineResult& r, const RefineOptions& options) {
  return {{"residual_rms",
           {{"value", r.normalized_rms},
            {"test_size", options.residual_test_size / 2},
            {"high", r.sigma_estimated ? nlohmann::json(options.rms_high) : nlohmann::json()}}},
          {"lag1", {{"value", r.lag1}, {"test_size", options.residual_test_size / 2}}},
          {"jump_count", {{"model", r.model_jumps}, {"detected", r.detected_jumps}}},
          {"iterations", {{"value", r.iterations}, {"limit", options.max_iterations}}},
          {"initial_cost", r.initial_cost},
          {"final_cost", r.final_cost}};
}

// The estimates against the truth in units of the CRLB (when the bound is known), as printed.
nlohmann::json CrlbJson(const RefineResult& r, const HybridParameters& truth_params, const Crlb& bound) {
  if (!bound.ok()) return nullptr;
  const Vec theta = r.estimate.Theta(r.unknowns), truth = truth_params.Theta(r.unknowns);
  const Vec error = theta - truth;
  const bool se = r.standard_errors.size() == static_cast<Eigen::Index>(r.names.size());
  auto vec = [](const Vec& v) { return std::vector<double>(v.data(), v.data() + v.size()); };
  return {
      {"sd", vec(bound.sd)},
      {"truth", vec(truth)},
      {"error", vec(error)},
      {"error_in_sd", vec(error.cwiseAbs().cwiseQuotient(bound.sd))},
      {"se_over_sd", se ? nlohmann::json(vec(r.standard_errors.cwiseQuotient(bound.sd))) : nlohmann::json()},
      {"mean_e_alpha", bound.mean_e_alpha},
      {"mean_e_beta", bound.mean_e_beta}};
}

// singular-fisher at the noise: {name: {value, standard_error}} at the refined point for each unknown
// the data determine (RefineResult::determined_standard_errors); null otherwise.
nlohmann::json DeterminedJson(const RefineResult& r) {
  const Vec& se = r.determined_standard_errors;
  if (se.size() != static_cast<Eigen::Index>(r.names.size())) return nullptr;
  const Vec theta = r.refined.Theta(r.unknowns);
  nlohmann::json out = nlohmann::json::object();
  for (std::size_t i = 0; i < r.names.size(); ++i) {
    const auto ii = static_cast<Eigen::Index>(i);
    if (!std::isnan(se[ii])) out[r.names[i]] = {{"value", theta[ii]}, {"standard_error", se[ii]}};
  }
  return out;
}

// The refinement's part of the report, added to the recursive run's `report` (RecursiveJson).
nlohmann::json RefinementJson(nlohmann::json j, const RefineResult& r, const IdentifyResult& recursive,
                      const std::string& refine, const RefineOptions& options) {
  auto vec = [](const Vec& v) { return std::vector<double>(v.data(), v.data() + v.size()); };
  j["refine"] = refine;
  j["status"] = refine == "none" ? "recursive" : ToString(r.status);
  j["reason"] = r.reason;
  j["route"] = r.route;
  j["routes_tried"] = r.routes_tried;
  j["reported"] = refine != "none" && r.reported;
  j["names"] = r.names;
  j["estimate"] = vec(r.estimate.Theta(r.unknowns));
  j["recursive_estimate"] = vec(r.start.Theta(r.unknowns));
  j["alpha"] = vec(r.estimate.alpha);
  j["beta"] = vec(r.estimate.beta);
  j["gamma"] = vec(r.estimate.gamma);
  j["standard_errors"] = vec(r.standard_errors);
  j["determined"] = DeterminedJson(r);
  nlohmann::json cov = nlohmann::json::array();
  for (Eigen::Index i = 0; i < r.covariance.rows(); ++i) cov.push_back(vec(r.covariance.row(i).transpose()));
  j["covariance"] = cov;
  j["sigma"] = vec(r.sigma);
  j["sigma_estimated"] = r.sigma_estimated;
  j["normalized_rms"] = r.normalized_rms;
  j["lag1"] = r.lag1;
  j["iterations"] = r.iterations;
  if (refine != "none") j["checks"] = ChecksJson(r, options);
  j["detector"] = {{"jumps_detected", recursive.jumps_detected},
                   {"flow_estimator", ToString(recursive.flow_status)},
                   {"flow_estimator_reason", recursive.flow_reason},
                   {"jump_estimator", ToString(recursive.jump_status)},
                   {"jump_estimator_reason", recursive.jump_reason}};
  if (recursive.safe_start && refine != "none") {
    j["start"] = {{"estimator", "rls"},
                  {"reason", recursive.safe_start_reason},
                  {"jumps_detected", recursive.safe_start->jumps_detected}};
  }
  j["model_jumps"] = r.model_jumps;
  j["samples_used"] = r.samples_used;
  j["span_reason"] = r.span_reason;
  j["start_repair"] = r.start_repair;
  j["mended"] = r.mended;
  if (!r.chain_x0.empty()) {
    nlohmann::json x0 = nlohmann::json::array();
    for (const Vec& v : r.chain_x0) x0.push_back(v.size() ? nlohmann::json(vec(v)) : nlohmann::json());
    j["chain_x0"] = x0;
    j["chain_samples_used"] = r.chain_samples_used;
    j["chain_span_reason"] = r.chain_span_reason;
    j["chains_used"] = r.chains_used;
    j["chains_skipped"] = r.chains_skipped;
    j["gaps_joined"] = r.gaps_joined;
  }
  return j;
}
}  // namespace

std::vector<long> ChainNumbers(const SampleData& data) {
  std::vector<long> chain(data.t.size());
  long c = 0;
  for (std::size_t k = 0; k < data.t.size(); ++k) chain[k] = c += data.chain_start[k];
  return chain;
}


std::vector<FitColumn> FitColumns(const ModelSpec& spec, const std::vector<int>& measured, const Mat& y,
                                  const FittedOutputs& f) {
  const auto& names = spec.state_names;
  std::vector<FitColumn> cols;
  for (std::size_t i = 0; i < names.size(); ++i) {
    cols.push_back({"fit_" + names[i], [&f, i](long k) { return f.x(Eigen::Index(i), k); }});
  }
  for (std::size_t i = 0; i < names.size(); ++i) {
    cols.push_back({"sd_" + names[i], [&f, i](long k) { return f.sd(Eigen::Index(i), k); }});
  }
  const bool full = y.rows() == static_cast<Eigen::Index>(names.size());
  for (std::size_t r = 0; r < measured.size(); ++r) {
    const int i = measured[r];
    const Eigen::Index row = full ? i : Eigen::Index(r);
    cols.push_back(
        {"residual_" + names[std::size_t(i)], [&f, &y, i, row](long k) { return y(row, k) - f.matched(i, k); }});
  }
  for (std::size_t i = 0; i < names.size(); ++i) {
    cols.push_back({"recursive_" + names[i], [&f, i](long k) { return f.recursive(Eigen::Index(i), k); }});
  }
  cols.push_back({"in_fit", [&f](long k) { return double(f.in_fit[std::size_t(k)]); }});
  if (!f.mode.empty()) {
    cols.push_back({"mode_fitted", [&f](long k) {
                      return f.mode[std::size_t(k)] >= 0 ? double(f.mode[std::size_t(k)]) : kNan;
                    }});
  }
  return cols;
}


nlohmann::json FittedEventsJson(const ModelSpec& spec, const std::vector<double>& t, const FittedOutputs& f) {
  auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  const bool automaton = IsAutomaton(spec);
  const std::vector<JumpMap> maps = automaton ? JumpMaps(spec) : std::vector<JumpMap>{};
  auto mode_name = [&](int q) {
    return q >= 0 && q < static_cast<int>(spec.modes.size()) ? nlohmann::json(spec.modes[std::size_t(q)])
                                                              : nlohmann::json(q);
  };
  nlohmann::json jumps = nlohmann::json::array();
  for (const FittedJump& j : f.jumps) {
    nlohmann::json e = {{"t", j.time}, {"se", number(j.se)}, {"chain", j.chain + 1}, {"in_fit", j.in_fit}};
    if (automaton) {
      e["map"] = j.map >= 0 && j.map < static_cast<int>(maps.size()) ? nlohmann::json(maps[std::size_t(j.map)].name)
                                                                    : nlohmann::json();
      e["mode_after"] = mode_name(j.mode_after);
    }
    jumps.push_back(e);
  }
  nlohmann::json modes = nlohmann::json::array();
  for (std::size_t k = 0; k < f.mode.size(); ++k) {
    if (f.mode[k] >= 0 && (k == 0 || f.mode[k] != f.mode[k - 1]))
      modes.push_back({{"first_sample", k}, {"t", t[k]}, {"mode", mode_name(f.mode[k])}});
  }
  return {{"jumps", jumps},
          {"modes", f.mode.empty() ? nlohmann::json() : modes},
          {"reason", f.reason},
          {"recursive_reason", f.recursive_reason}};
}


nlohmann::json RecursiveJson(const Model& model, const SampleData& data, const IdentifierSettings& settings,
                             const std::string& accuracy_source, const IdentifyResult& result) {
  const std::vector<long> chain = ChainNumbers(data);
  nlohmann::json out = {{"model", model.spec().name},
                        {"data", DataJson(data)},
                        {"settings", SettingsJson(settings, accuracy_source)},
                        {"noise", NoiseJson(result)},
                        {"recursive", RecursiveResultJson(result)},
                        {"detections", DetectionsJson(data, result, chain)},
                        {"chains", ChainsJson(data, result, chain)},
                        {"automaton", EventsJson(model, data, result)},
                        {"truth", nullptr}};
  if (data.j) out["truth"] = TruthJson(model, *data.j, result);
  return out;
}

nlohmann::json OutcomeJson(const IdentifyOutcome& outcome) {
  const Model& model = outcome.model;
  const SampleData& data = outcome.data;
  const PartialOutputs& partial = outcome.partial;
  const RefineStep& step = outcome.refinement;
  const RefineResult& r = step.result;
  nlohmann::json j = RefinementJson(outcome.recursive_report, r, outcome.recursive, outcome.refine, step.options);
  j["samples"] = data.y.cols();
  j["min_chain_samples"] = 2 * model.state_size() + 2;
  j["fit_t_end"] = data.uniform && r.samples_used > 0
                       ? nlohmann::json(static_cast<double>(step.span() - 1) * data.dt)
                       : nlohmann::json();
  if (outcome.refine == "ml" && IsAutomaton(model.spec()) && j.contains("automaton")) {
    AddFittedEventsJson(step.fitted, &j["automaton"]);
  }
  if (step.bound.ok())
    j["crlb_sd"] = std::vector<double>(step.bound.sd.data(), step.bound.sd.data() + step.bound.sd.size());
  j["crlb"] = CrlbJson(r, step.truth, step.bound);
  j["fitted_events"] = FittedEventsJson(model.spec(), data.t, step.outputs);
  // The states the data held, those reconstructed as the recursive pass's start, and x0 held.
  auto named = [&](const std::vector<int>& indices) {
    std::vector<std::string> out;
    for (const int i : indices) out.push_back(model.spec().state_names[static_cast<std::size_t>(i)]);
    return out;
  };
  j["measured"] = named(partial.measured.empty() ? MeasuredIndices(model) : partial.measured);
  j["reconstructed"] = named(partial.reconstructed);
  if (!partial.reconstruction.empty()) j["reconstruction"] = partial.reconstruction;
  j["x0_known"] = named(step.known);
  j["fit_outliers"] = OutliersJson(data, step.fit_outliers);
  j["notes"] = step.notes;
  return j;
}

}  // namespace hysid
