// hysid.identify: every option of `hysid identify` as a keyword. The detector's and the estimators'
// options come from their tables (PluginOptionArguments, experiments/cli/checks.hpp: the same list
// the command line builds its flags from), with their help texts and defaults in the docstring.
#include <pybind11/stl.h>

#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/identify/identifier.hpp"
#include "core/io/sample_data.hpp"
#include "experiments/cli/checks.hpp"
#include "python/binding.hpp"
#include "sim/refine/refine.hpp"

namespace hysid::python {
namespace {

// identify's keywords besides the plugin options: name, default as Python spells it, help.
struct Keyword {
  std::string name, default_text, help;
};

template <class Descriptor>
std::string PluginList(const std::vector<Descriptor>& all) {
  std::vector<std::string> parts;
  for (const Descriptor& d : all) parts.push_back(fmt::format("'{}' ({})", d.name, d.help));
  return fmt::format("{}", fmt::join(parts, "; "));
}

const std::vector<Keyword>& OwnKeywords() {
  static const std::vector<Keyword> keywords{
      {"estimator", "'rls'", "estimator of alpha and beta: " + PluginList(AllPlugins<EstimatorKind>())},
      {"detector", "'residual'", "jump detector: " + PluginList(AllPlugins<DetectorKind>())},
      {"sigma", "None",
       "known measurement noise sigma (one number, or one per state); None: estimated where needed"},
      {"max_gap", "None", "seconds: a step longer than this restarts the chain; None: 5 x the median step"},
      {"localize", "False", "regress each jump at its located instant inside (t-dt, t]"},
      {"second_pass", "False", "re-classify every sample with the final estimates and re-estimate"},
      {"sets", "True", "compute the hulls flow_hull and jump_hull"},
      {"trace", "True", "return alpha_trace and beta_trace (the estimates after every sample)"},
      {"data_rtol", "0.0", "residual detector: relative accuracy of the data apart from the noise"},
      {"data_atol", "0.0", "residual detector: absolute accuracy of the data apart from the noise"},
      {"flow_noise_shape", "None",
       "gtls/frisch: noise covariance shape C of the flow rows [phi, y] ((p+1) x (p+1), or its p+1 squared "
       "values row-major) instead of the one derived from sigma and dt"},
      {"jump_noise_shape", "None", "gtls/frisch: the same for the jump rows"},
      {"refine", "'ml'",
       "'ml': maximum-likelihood output-error refinement of the recursive estimate (the dict's `refined`); "
       "'none': the recursive estimate alone"},
  };
  return keywords;
}

// The plugin options by keyword ("forgetting", "jump_forgetting").
const std::map<std::string, const PluginOptionArgument*>& PluginKeywords() {
  static const auto* by_name = [] {
    auto* m = new std::map<std::string, const PluginOptionArgument*>;
    for (const PluginOptionArgument& a : PluginOptionArguments())
      (*m)[Spelled(a.name, Spelling::kKeyword, a.prefix)] = &a;
    return m;
  }();
  return *by_name;
}

std::vector<std::string> AllKeywords() {
  std::vector<std::string> names;
  for (const Keyword& k : OwnKeywords()) names.push_back(k.name);
  for (const auto& [name, a] : PluginKeywords()) names.push_back(name);
  return names;
}

struct IdentifyArgs {
  std::string estimator = "rls", detector = "residual";
  std::map<std::string, std::string> options;  // the plugin options given (not None), as text
  std::vector<double> sigma;
  std::optional<double> max_gap;
  double data_rtol = 0.0, data_atol = 0.0;
  bool localize = false, second_pass = false, sets = true, trace = true;
  Mat flow_shape, jump_shape;
  std::string refine = "ml";
};

// A plugin option's value as the command line's text: a number as the shortest text that reads
// back to it, a choice's name as given.
std::string OptionText(const py::handle& value, const std::string& name) {
  if (py::isinstance<py::str>(value)) return value.cast<std::string>();
  if (py::isinstance<py::int_>(value) && !py::isinstance<py::bool_>(value)) return py::str(value);
  return fmt::format("{}", Number(value, name));
}

// A noise shape: a square array or its values row-major; errors as the command line's.
Mat NoiseShape(const py::handle& value, const std::string& name) {
  if (value.is_none()) return Mat();
  const py::array_t<double> a = RealArray(value, name);
  if (a.ndim() > 2 || (a.ndim() == 2 && a.shape(0) != a.shape(1))) {
    throw std::invalid_argument(
        fmt::format("{}: shape {}: give a square matrix (parameters + 1)^2", name, ShapeText(a)));
  }
  const std::vector<double> v(a.data(), a.data() + a.size());
  CheckFinite(name, v);
  const auto m = static_cast<Eigen::Index>(std::lround(std::sqrt(double(v.size()))));
  if (m * m != static_cast<Eigen::Index>(v.size())) {
    throw std::invalid_argument(
        fmt::format("{} has {} values: give a square matrix (parameters + 1)^2, row-major", name, v.size()));
  }
  return Mat(Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      v.data(), m, m));
}

IdentifyArgs ParseKeywords(const py::kwargs& kwargs) {
  IdentifyArgs a;
  const std::vector<std::string> known = AllKeywords();
  for (const auto& [key, value] : kwargs) {
    const std::string name = key.cast<std::string>();
    if (PluginKeywords().contains(name)) {
      if (!value.is_none()) a.options[name] = OptionText(value, name);
    } else if (name == "estimator" || name == "detector") {
      (name == "estimator" ? a.estimator : a.detector) = Text(value, name);
    } else if (name == "refine") {
      a.refine = Text(value, name);
    } else if (name == "sigma") {
      a.sigma = Numbers(value, name);
    } else if (name == "max_gap") {
      a.max_gap = OptionalNumber(value, name);
    } else if (name == "data_rtol" || name == "data_atol") {
      (name == "data_rtol" ? a.data_rtol : a.data_atol) = Number(value, name);
    } else if (name == "flow_noise_shape" || name == "jump_noise_shape") {
      (name == "flow_noise_shape" ? a.flow_shape : a.jump_shape) = NoiseShape(value, name);
    } else if (name == "localize" || name == "second_pass" || name == "sets" || name == "trace") {
      const bool v = Flag(value, name);
      (name == "localize"      ? a.localize
       : name == "second_pass" ? a.second_pass
       : name == "sets"        ? a.sets
                               : a.trace) = v;
    } else {
      throw py::type_error(
          fmt::format("identify() got an unexpected keyword argument '{}'; its keywords are model, "
                      "y, dt, t, {}",
                      name, fmt::join(known, ", ")));
    }
  }
  if (a.refine != "ml" && a.refine != "none")
    throw std::invalid_argument(fmt::format("refine = '{}': expected 'none' or 'ml'", a.refine));
  return a;
}

// The identifier's settings, checked as `hysid identify` checks its flags, with the same messages.
IdentifierSettings Settings(const IdentifyArgs& a, const Model& model) {
  IdentifierSettings s;
  SetPluginKinds(a.estimator, a.detector, Spelling::kKeyword, &s);
  ApplyPluginOptions(a.options, Spelling::kKeyword, &s);
  s.flow_estimator.noise_shape = a.flow_shape;
  s.jump_estimator.noise_shape = a.jump_shape;
  CheckDataAccuracy(a.data_rtol, a.data_atol, Spelling::kKeyword);
  s.localize = a.localize;
  s.second_pass = a.second_pass;
  s.sets = a.sets;
  if (!a.sigma.empty()) s.sigma = CheckedSigma(a.sigma, model.state_size(), true, Spelling::kKeyword);
  s.data_rtol = a.data_rtol;
  s.data_atol = a.data_atol;
  try {
    Identifier check(model, 1.0, s);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(fmt::format("estimator/detector/*_noise_shape: {}", e.what()));
  }
  return s;
}

// The unknown entries of `values` by name.
py::dict Unknowns(const std::vector<Parameter>& params, const Vec& values) {
  py::dict out;
  for (std::size_t i = 0; i < params.size(); ++i) {
    if (!params[i].known) out[py::str(params[i].name)] = values[Eigen::Index(i)];
  }
  return out;
}

py::dict ByName(const std::vector<std::string>& names, const Vec& values) {
  py::dict out;
  for (std::size_t i = 0; i < names.size() && Eigen::Index(i) < values.size(); ++i)
    out[py::str(names[i])] = values[Eigen::Index(i)];
  return out;
}

// The samples of a fit: y (n × K) at k·dt, or at the times and in the chains of `chains`.
struct FitInput {
  Mat y;
  double dt = 0.0;
  std::optional<SampleData> chains;
};

struct FitOutcome {
  IdentifyResult recursive;
  std::optional<RefineResult> refined;
};

// The identifier and (refine 'ml') the refinement from RefinementStart, as `hysid identify`.
FitOutcome RunFit(const Model& model, const FitInput& in, const IdentifierSettings& settings, bool trace,
                  bool refine) {
  IdentifyOptions options{.trace = trace};
  if (in.chains) {
    options.times = in.chains->t;
    options.chain_start = in.chains->chain_start;
  }
  FitOutcome out;
  out.recursive = hysid::Identify(model, in.y, in.dt, settings, options);
  if (!refine) return out;
  RefineOptions refine_options;
  refine_options.sigma = settings.sigma;
  std::vector<double> t(static_cast<std::size_t>(in.y.cols()));
  for (std::size_t k = 0; k < t.size(); ++k)
    t[k] = in.chains ? in.chains->t[k] : static_cast<double>(k) * in.dt;
  out.refined =
      RefineIdentification(model, t, in.y, in.chains ? in.chains->chain_start : std::vector<std::uint8_t>{},
                           RefinementStart(out.recursive), refine_options);
  return out;
}

// The refinement's dict: the keys of `hysid identify --json` (names, sigma, normalized_rms, lag1,
// iterations, ...), the estimates also by name.
py::dict RefinedDict(const RefineResult& r, const IdentifyResult& given, bool chains) {
  py::dict out;
  out["status"] = ToString(r.status);
  out["reason"] = r.reason;
  out["names"] = r.names;
  out["estimates"] = ByName(r.names, r.estimate.Theta(r.unknowns));
  out["recursive_estimates"] = ByName(r.names, r.start.Theta(r.unknowns));
  out["standard_errors"] = ByName(r.names, r.standard_errors);  // empty unless the fit is ok
  out["covariance"] = Transposed(r.covariance);
  out["alpha"] = ToArray(r.estimate.alpha);
  out["beta"] = ToArray(r.estimate.beta);
  out["x0"] = ToArray(r.estimate.x0);
  out["sigma"] = ToArray(r.sigma);
  out["sigma_estimated"] = r.sigma_estimated;
  out["normalized_rms"] = r.normalized_rms;
  out["lag1"] = r.lag1;
  out["iterations"] = r.iterations;
  out["samples_used"] = r.samples_used;
  out["span_reason"] = r.span_reason;
  out["model_jumps"] = r.model_jumps;
  out["start_repair"] = r.start_repair;
  out["mended"] = r.mended;  // detections mended from the fitted model ("" when none)
  out["start"] = given.safe_start ? given.safe_start_reason : std::string("the recursive estimate");
  if (chains) {
    py::list x0;
    for (const Vec& v : r.chain_x0) x0.append(v.size() ? py::object(ToArray(v)) : py::object(py::none()));
    out["chain_x0"] = x0;
    out["chain_samples_used"] = r.chain_samples_used;
    out["chain_span_reason"] = r.chain_span_reason;
    out["chains_used"] = r.chains_used;
    out["chains_skipped"] = r.chains_skipped;
  }
  return out;
}

py::dict FitDict(const Model& model, const FitOutcome& f, bool trace, bool chains) {
  const IdentifyResult& r = f.recursive;
  const ModelSpec& spec = model.spec();
  py::dict out;
  out["alpha"] = ToArray(r.alpha_hat);
  out["beta"] = ToArray(r.beta_hat);
  py::dict estimates = Unknowns(spec.alpha, r.alpha_hat);
  for (auto [k, v] : Unknowns(spec.beta, r.beta_hat)) estimates[k] = v;
  out["estimates"] = estimates;
  out["gamma"] = py::array_t<std::uint8_t>(py::ssize_t(r.gamma.size()), r.gamma.data());
  out["statistic"] = py::array_t<double>(py::ssize_t(r.statistic.size()), r.statistic.data());
  out["threshold"] = py::array_t<double>(py::ssize_t(r.threshold.size()), r.threshold.data());
  if (trace) {
    out["alpha_trace"] = Transposed(r.alpha_trace);
    out["beta_trace"] = Transposed(r.beta_trace);
  }
  out["jumps_detected"] = r.jumps_detected;
  out["flow_status"] = ToString(r.flow_status);
  out["jump_status"] = ToString(r.jump_status);
  out["flow_reason"] = r.flow_reason;
  out["jump_reason"] = r.jump_reason;
  out["flow_hull"] = Transposed(r.flow_hull);
  out["jump_hull"] = Transposed(r.jump_hull);
  out["sets_skipped"] = r.sets_skipped;
  if (f.refined) out["refined"] = RefinedDict(*f.refined, r, chains);
  return out;
}

bool IsList(const py::handle& o) { return py::isinstance<py::list>(o) || py::isinstance<py::tuple>(o); }

// y is a list of runs when it is a list or tuple that is not one run's rows (a 2-D array of numbers).
bool IsRuns(const py::handle& y) {
  if (!IsList(y)) return false;
  try {
    return py::module_::import("numpy").attr("asarray")(y).cast<py::array>().ndim() != 2;
  } catch (const py::error_already_set&) {
    return true;  // ragged: arrays of different lengths, one per run
  }
}

// One run's samples, (samples, n) as n × K.
Mat Samples(const py::handle& y, int n, const std::string& what) {
  const py::array_t<double> a = RealArray(y, what);
  if (a.ndim() != 2 || a.shape(1) != n) {
    throw std::invalid_argument(fmt::format(
        "{} must be a (samples, {}) array, one row per sample; got shape {}", what, n, ShapeText(a)));
  }
  return Eigen::Map<const Mat>(a.data(), n, a.shape(0));  // row-major K × n = n × K
}

std::vector<double> Times(const py::handle& t, const std::string& what) {
  const py::array_t<double> a = RealArray(t, what);
  if (a.ndim() != 1) {
    throw std::invalid_argument(
        fmt::format("{} must be a 1-D array of times, one per sample; got shape {}", what, ShapeText(a)));
  }
  return std::vector<double>(a.data(), a.data() + a.size());
}

// y and t as runs, checked as `hysid identify --data` checks its files; messages name y and t.
SampleData RunsOf(const Model& model, const py::object& y, const py::object& t, double dt, double max_gap) {
  const bool runs = IsRuns(y);
  const py::list ys = runs ? py::list(y) : py::list(py::make_tuple(y));
  if (ys.empty())
    throw std::invalid_argument("y: an empty list; give a (samples, n) array, or a list of runs");
  std::vector<Mat> samples;
  std::vector<std::vector<double>> times(ys.size());
  for (std::size_t r = 0; r < ys.size(); ++r)
    samples.push_back(Samples(ys[r], model.state_size(), runs ? fmt::format("y[{}]", r) : "y"));
  if (!t.is_none()) {
    if (runs && (!IsList(t) || py::len(t) != ys.size())) {
      throw std::invalid_argument(
          fmt::format("t: y is a list of {} runs; give t as a list of as many 1-D arrays", ys.size()));
    }
    for (std::size_t r = 0; r < ys.size(); ++r)
      times[r] = Times(runs ? py::object(py::list(t)[r]) : t, runs ? fmt::format("t[{}]", r) : "t");
  }
  try {
    py::gil_scoped_release release;
    return SampleDataFromArrays(times, samples, dt, {.max_gap = max_gap});
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(ArrayMessage(e.what(), runs));
  }
}

py::dict Identify(const py::object& model_arg, const py::object& y, const py::object& dt_arg,
                  const py::object& t, const py::kwargs& kwargs) {
  const Model model = ModelArgument(model_arg).model;
  RefuseBeyondModule(model, "identify", /*partial_ok=*/false);
  const IdentifyArgs args = ParseKeywords(kwargs);
  const std::optional<double> dt = OptionalNumber(dt_arg, "dt");
  if (dt && (!(*dt > 0.0) || !std::isfinite(*dt)))
    throw std::invalid_argument(fmt::format("dt = {}: must be > 0", *dt));
  if (args.max_gap && (!(*args.max_gap > 0.0) || !std::isfinite(*args.max_gap))) {
    throw std::invalid_argument(fmt::format("max_gap = {}: must be a number > 0 (seconds)", *args.max_gap));
  }
  if (t.is_none() && !dt) throw std::invalid_argument("dt: required when t is not given");
  const IdentifierSettings settings = Settings(args, model);
  // The checks of `hysid identify --data` (sample count and limit, time steps), on every path.
  SampleData data = RunsOf(model, y, t, dt.value_or(0.0), args.max_gap.value_or(0.0));
  if (dt && !t.is_none() && !(std::abs(data.dt - *dt) <= 1e-6 * *dt)) {
    throw std::invalid_argument(fmt::format("dt = {}: t has {} step {}; give dt or t, or both that agree",
                                            *dt, data.uniform ? "the" : "the median", data.dt));
  }
  FitInput in;
  const bool grid =
      t.is_none() && !args.max_gap && !IsRuns(y) && static_cast<std::size_t>(data.y.cols()) == py::len(y);
  if (grid) {  // one run on the grid k·dt, no sample missing: the grid's own dt
    in.y = std::move(data.y);
    in.dt = *dt;
  } else {
    in.y = data.y;
    in.dt = data.dt;
    if (!data.uniform) in.chains = data;
  }
  const bool refine = args.refine == "ml", trace = args.trace;
  const FitOutcome f = RunInterruptible<FitOutcome>(
      [model, in, settings, trace, refine] { return RunFit(model, in, settings, trace, refine); });
  py::dict out = FitDict(model, f, trace, in.chains.has_value());
  if (!grid) {
    out["t"] = py::array_t<double>(py::ssize_t(data.t.size()), data.t.data());
    out["run"] = py::array_t<int>(py::ssize_t(data.run.size()), data.run.data());
    out["chains"] = data.chains();
    out["missing_rows"] = data.missing_rows;
  }
  return out;
}

// Every keyword with its default and help, for the docstring and hysid.identify_options().
std::string Docstring() {
  std::string doc =
      "The identifier on samples y, as `hysid identify` (every flag of the command line is a keyword; the "
      "same checks and messages). y: (samples, states) at spacing dt, or at times t (one per sample); a "
      "list of such arrays (and of times) is several runs of one system (alpha, beta shared). A row with "
      "a NaN is left out (an infinite value is refused) and restarts the chain, as does a step longer than "
      "max_gap. An unknown keyword, and an option the chosen detector or estimator does not read, is "
      "refused.\n\n"
      "Returns a dict: alpha, beta (full vectors), estimates (the unknowns by name), gamma, statistic, "
      "threshold, alpha_trace, beta_trace, jumps_detected, flow_status, jump_status, flow_reason, "
      "jump_reason, flow_hull, jump_hull, sets_skipped; with refine='ml' also refined (the keys of "
      "`hysid identify --json`: status, reason, names, estimates, recursive_estimates, standard_errors, "
      "covariance, alpha, beta, x0, sigma, sigma_estimated, normalized_rms, lag1, iterations, samples_used, "
      "span_reason, model_jumps, start_repair, mended, start; with runs or times also chain_x0, "
      "chain_samples_used, chain_span_reason, chains_used, chains_skipped). With t, runs, NaN rows or "
      "max_gap the per-sample arrays are over the samples used, listed in t and run, with chains and "
      "missing_rows. Ctrl-C raises KeyboardInterrupt.\n\nKeywords:\n";
  for (const Keyword& k : OwnKeywords())
    doc += fmt::format("  {} = {}: {}\n", k.name, k.default_text, k.help);
  for (const PluginOptionArgument& a : PluginOptionArguments()) {
    doc += fmt::format("  {} = None (default {}): {}\n", Spelled(a.name, Spelling::kKeyword, a.prefix),
                       a.default_text, a.help);
  }
  return doc;
}

const char* TypeName(OptionType type) {
  return type == OptionType::kReal ? "real" : type == OptionType::kInteger ? "integer" : "choice";
}

// {keyword: {default, help, type, choices, read_by}} for every plugin option.
py::dict OptionTable() {
  py::dict out;
  for (const PluginOptionArgument& a : PluginOptionArguments()) {
    py::dict d;
    d["default"] = a.default_text;
    d["help"] = a.help;
    d["type"] = TypeName(a.type);
    d["choices"] = a.choices;
    d["read_by"] = a.read_by;
    d["flag"] = Spelled(a.name, Spelling::kFlag, a.prefix);
    d["family"] = FindOption(DetectorOptions(), a.name) ? "detector" : "estimator";
    out[py::str(Spelled(a.name, Spelling::kKeyword, a.prefix))] = d;
  }
  return out;
}

}  // namespace

void BindIdentify(py::module_& m) {
  static const std::string* doc = new std::string(Docstring());  // the docstring must outlive the module
  m.def("identify", &Identify, py::arg("model"), py::arg("y"), py::arg("dt") = py::none(),
        py::arg("t") = py::none(), doc->c_str());
  m.def("identify_options", &OptionTable,
        "The detector's and the estimators' options that identify takes as keywords (the tables the command "
        "line's flags come from): {keyword: {default, help, type, choices, read_by, flag, family}}");
  m.def(
      "plugins",
      [] {
        py::dict d;
        d["estimator"] = PluginNames<EstimatorKind>();
        d["detector"] = PluginNames<DetectorKind>();
        return d;
      },
      "The estimators and detectors by name: {'estimator': [...], 'detector': [...]}");
}

}  // namespace hysid::python
