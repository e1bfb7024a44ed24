// hysid.identify: the settings of `hysid identify` as keywords, translated into an IdentifyRequest
// (experiments/request/request.hpp) and its outcome into a dict: the report (OutcomeJson) as JSON, its
// `refined` part and recursive keys read from it, plus the per-sample arrays. The keywords come from the
// tables the command line builds its flags from: the identification's own settings (IdentifySettings,
// experiments/request/settings.hpp) and the detector's and the estimators' options (PluginOptionArguments,
// experiments/request/checks.hpp), with their help texts and defaults in the docstring; Python adds its own
// (PythonKeywords: the arrays, the truth, what the dict holds).
#include <pybind11/stl.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/identify/identifier.hpp"
#include "core/io/sample_data.hpp"
#include "experiments/request/checks.hpp"
#include "experiments/request/outcome_json.hpp"
#include "experiments/request/request.hpp"
#include "experiments/request/settings.hpp"
#include "python/binding.hpp"
#include "sim/refine/refine.hpp"

namespace hysid::python {
namespace {

// The keywords only Python has (the settings both front-ends have: IdentifySettings,
// experiments/request/settings.hpp): name, default as Python spells it, help.
struct Keyword {
  std::string name, default_text, help;
};

const std::vector<Keyword>& PythonKeywords() {
  static const std::vector<Keyword> keywords{
      {"sets", "True", "compute the hulls flow_hull and jump_hull"},
      {"trace", "True", "return alpha_trace and beta_trace (the estimates after every sample)"},
      {"u", "None",
       "a model with inputs: the measured inputs, aligned with y: a (samples, inputs) array, or a dict input "
       "name -> one value per sample (a list of those for runs)"},
      {"truth", "None",
       "the truth the report compares with: {'j': the true jump counter per sample (as simulate's j), "
       "optionally 'x0' and 'sigma' (the simulation's: the CRLB at the truth)}"},
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

// Every keyword besides model, y, dt and t: the settings, Python's own, the plugin options.
std::vector<std::string> AllKeywords() {
  std::vector<std::string> names;
  for (const IdentifySetting& s : IdentifySettings()) names.push_back(Spelled(s.name, Spelling::kKeyword));
  for (const Keyword& k : PythonKeywords()) names.push_back(k.name);
  for (const auto& [name, a] : PluginKeywords()) names.push_back(name);
  return names;
}

// The keywords: those that are the identification's settings straight into the request (the samples
// and the truth are added later), the rest beside it.
struct IdentifyArgs {
  explicit IdentifyArgs(Model model) : request(std::move(model)) {
    request.trace = true;
    request.spelling = Spelling::kKeyword;
  }
  IdentifyRequest request;
  std::optional<double> max_gap;
  py::object u = py::none(), truth = py::none();
  std::vector<std::string> bounds;  // ApplyBounds' texts, NAME=LO,HI
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
  return NoiseShapeOf(std::vector<double>(a.data(), a.data() + a.size()), name, Spelling::kKeyword);
}

// Reads one keyword's value into the arguments.
using KeywordReader = std::function<void(IdentifyArgs&, const py::handle&, const std::string&)>;

// The reader of every setting and of Python's own keywords, by keyword; built once, and only when each
// name of IdentifySettings and PythonKeywords has exactly one reader (an internal error otherwise).
const std::map<std::string, KeywordReader>& KeywordReaders() {
  static const auto* readers = [] {
    using A = IdentifyArgs;
    using V = const py::handle&;
    using N = const std::string&;
    auto* m = new std::map<std::string, KeywordReader>{
        {"estimator", [](A& a, V v, N n) { a.request.estimator = Text(v, n); }},
        {"detector", [](A& a, V v, N n) { a.request.detector = Text(v, n); }},
        {"refine", [](A& a, V v, N n) { a.request.refine = Text(v, n); }},
        {"u", [](A& a, V v, N) { a.u = py::reinterpret_borrow<py::object>(v); }},
        {"truth", [](A& a, V v, N) { a.truth = py::reinterpret_borrow<py::object>(v); }},
        {"x0_known", [](A& a, V v, N) { a.request.x0_known = X0KnownText(v); }},
        {"x0", [](A& a, V v, N n) { a.request.x0 = Numbers(v, n); }},
        {"param_bound", [](A& a, V v, N) { a.bounds = BoundTexts(v); }},
        {"sigma", [](A& a, V v, N n) { a.request.sigma = Numbers(v, n); }},
        {"max_gap", [](A& a, V v, N n) { a.max_gap = OptionalNumber(v, n); }},
        {"data_rtol",
         [](A& a, V v, N n) {
           a.request.data_rtol = Number(v, n);
           a.request.data_accuracy_source = "as given";
         }},
        {"data_atol",
         [](A& a, V v, N n) {
           a.request.data_atol = Number(v, n);
           a.request.data_accuracy_source = "as given";
         }},
        {"flow_noise_shape", [](A& a, V v, N n) { a.request.flow_noise_shape = NoiseShape(v, n); }},
        {"jump_noise_shape", [](A& a, V v, N n) { a.request.jump_noise_shape = NoiseShape(v, n); }},
        {"localize", [](A& a, V v, N n) { a.request.localize = Flag(v, n); }},
        {"second_pass", [](A& a, V v, N n) { a.request.second_pass = Flag(v, n); }},
        {"keep_outliers", [](A& a, V v, N n) { a.request.keep_outliers = Flag(v, n); }},
        {"sets", [](A& a, V v, N n) { a.request.sets = Flag(v, n); }},
        {"trace", [](A& a, V v, N n) { a.request.trace = Flag(v, n); }},
    };
    std::set<std::string> described;
    for (const IdentifySetting& s : IdentifySettings()) described.insert(Spelled(s.name, Spelling::kKeyword));
    for (const Keyword& k : PythonKeywords()) described.insert(k.name);
    std::set<std::string> read;
    for (const auto& [name, reader] : *m) read.insert(name);
    if (read != described) {
      std::fprintf(stderr,
                   "hysid: internal error: identify's keyword readers (%s) are not its settings (%s)\n",
                   fmt::format("{}", fmt::join(read, ", ")).c_str(),
                   fmt::format("{}", fmt::join(described, ", ")).c_str());
      std::abort();
    }
    return m;
  }();
  return *readers;
}

IdentifyArgs ParseKeywords(const py::kwargs& kwargs, const Model& model) {
  IdentifyArgs a(model);
  IdentifyRequest& r = a.request;
  for (const auto& [key, value] : kwargs) {
    const std::string name = key.cast<std::string>();
    if (PluginKeywords().contains(name)) {
      if (!value.is_none()) r.plugin_options[name] = OptionText(value, name);
    } else if (const auto reader = KeywordReaders().find(name); reader != KeywordReaders().end()) {
      reader->second(a, value, name);
    } else {
      throw py::type_error(
          fmt::format("identify() got an unexpected keyword argument '{}'; its keywords are model, "
                      "y, dt, t, {}",
                      name, fmt::join(AllKeywords(), ", ")));
    }
  }
  if (const std::string problem = RefineChoiceProblem(r.refine); !problem.empty())
    throw std::invalid_argument("refine: " + problem);
  CheckBoundsNeedRefinement(!a.bounds.empty(), r.refine, Spelling::kKeyword);
  return a;
}

py::object FromJson(const nlohmann::json& j) { return py::module_::import("json").attr("loads")(j.dump()); }

// A number of the report (NaN and infinities are written as null): null as NaN.
double Real(const nlohmann::json& j) { return j.is_number() ? j.get<double>() : std::nan(""); }

py::array_t<double> Array(const nlohmann::json& j) {
  py::array_t<double> out(py::ssize_t(j.size()));
  for (std::size_t i = 0; i < j.size(); ++i) out.mutable_at(py::ssize_t(i)) = Real(j[i]);
  return out;
}

// A matrix of the report (a list of rows) as Transposed returns the matrix: one row per column.
py::array_t<double> TransposedMatrix(const nlohmann::json& j) {
  const auto rows = py::ssize_t(j.size()), cols = rows > 0 ? py::ssize_t(j[0].size()) : 0;
  py::array_t<double> out({cols, rows});
  for (py::ssize_t r = 0; r < rows; ++r) {
    for (py::ssize_t c = 0; c < cols; ++c) out.mutable_at(c, r) = Real(j[std::size_t(r)][std::size_t(c)]);
  }
  return out;
}

// values[i] by names[i].
py::dict ByName(const nlohmann::json& names, const nlohmann::json& values) {
  py::dict out;
  for (std::size_t i = 0; i < names.size() && i < values.size(); ++i)
    out[py::str(names[i].get<std::string>())] = Real(values[i]);
  return out;
}

// The unknown entries of `values` (a list of the report) by the parameters' names.
void AddUnknowns(const std::vector<Parameter>& params, const nlohmann::json& values, py::dict* out) {
  for (std::size_t i = 0; i < params.size() && i < values.size(); ++i) {
    if (!params[i].known) (*out)[py::str(params[i].name)] = Real(values[i]);
  }
}

// The refinement's dict, read from the report (OutcomeJson): its keys, the estimates by name, x0 (the
// estimate's x0[...] entries) and where the fit started; with `chains` (runs or times) the per-chain keys.
py::dict RefinedDict(const nlohmann::json& report, bool chains) {
  py::dict out;
  for (const char* key : {"status", "reason", "route", "routes_tried", "reported", "names", "sigma_estimated",
                          "iterations", "samples_used", "span_reason", "model_jumps", "start_repair", "mended"})
    out[key] = FromJson(report.at(key));
  const nlohmann::json& names = report.at("names");
  out["estimates"] = ByName(names, report.at("estimate"));
  out["recursive_estimates"] = ByName(names, report.at("recursive_estimate"));
  out["standard_errors"] = ByName(names, report.at("standard_errors"));  // empty unless reported
  out["covariance"] = TransposedMatrix(report.at("covariance"));
  out["determined"] = FromJson(report.at("determined"));  // singular-fisher at the noise, else None
  // Samples the fit left out as outliers (RefitWithoutOutliers): [] when none.
  out["outliers"] = FromJson(report.value("fit_outliers", nlohmann::json::array()));
  for (const char* key : {"alpha", "beta", "sigma"}) out[key] = Array(report.at(key));
  nlohmann::json x0 = nlohmann::json::array();
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i].get<std::string>().starts_with("x0[")) x0.push_back(report.at("estimate")[i]);
  }
  out["x0"] = Array(x0);
  out["normalized_rms"] = Real(report.at("normalized_rms"));
  out["lag1"] = Real(report.at("lag1"));
  out["start"] = report.contains("start") ? report["start"].at("reason").get<std::string>()
                                          : std::string("the recursive estimate");
  if (chains) {
    py::list x0s;
    for (const nlohmann::json& v : report.value("chain_x0", nlohmann::json::array()))
      x0s.append(v.is_null() ? py::object(py::none()) : py::object(Array(v)));
    out["chain_x0"] = x0s;
    for (const char* key : {"chain_samples_used", "chain_span_reason"})
      out[key] = FromJson(report.value(key, nlohmann::json::array()));
    for (const char* key : {"chains_used", "chains_skipped", "gaps_joined"}) out[key] = FromJson(report.value(key, 0));
  }
  return out;
}

// The dict's recursive keys (from the report) and per-sample arrays (from the outcome).
py::dict FitDict(const Model& model, const IdentifyOutcome& f, const nlohmann::json& report, bool trace,
                 bool refine, bool chains) {
  const IdentifyResult& r = f.recursive;
  const nlohmann::json& recursive = report.at("recursive");
  const nlohmann::json& detector = report.at("detector");
  py::dict out;
  out["alpha"] = Array(recursive.at("alpha"));
  out["beta"] = Array(recursive.at("beta"));
  py::dict estimates;
  AddUnknowns(model.spec().alpha, recursive.at("alpha"), &estimates);
  AddUnknowns(model.spec().beta, recursive.at("beta"), &estimates);
  out["estimates"] = estimates;
  out["gamma"] = py::array_t<std::uint8_t>(py::ssize_t(r.gamma.size()), r.gamma.data());
  out["statistic"] = py::array_t<double>(py::ssize_t(r.statistic.size()), r.statistic.data());
  out["threshold"] = py::array_t<double>(py::ssize_t(r.threshold.size()), r.threshold.data());
  if (trace) {
    out["alpha_trace"] = Transposed(r.alpha_trace);
    out["beta_trace"] = Transposed(r.beta_trace);
  }
  out["jumps_detected"] = FromJson(detector.at("jumps_detected"));
  for (const auto& [key, from] : {std::pair{"flow_status", "flow_estimator"}, std::pair{"jump_status", "jump_estimator"},
                                  std::pair{"flow_reason", "flow_estimator_reason"},
                                  std::pair{"jump_reason", "jump_estimator_reason"}})
    out[key] = FromJson(detector.at(from));
  out["flow_hull"] = Transposed(r.flow_hull);
  out["jump_hull"] = Transposed(r.jump_hull);
  out["sets_skipped"] = FromJson(recursive.at("sets_skipped"));
  if (refine) out["refined"] = RefinedDict(report, chains);
  out["notes"] = FromJson(report.at("notes"));  // an estimate far from its start value: "check the units"
  return out;
}

// What a fit figure reads, as `hysid identify --trace` has it per sample (hysid_plots.fit.plot_fit):
// run, chain, t, missing (0: the samples), the measured samples (samples, measured states) and the
// fitted model's columns (FitColumns: fit_STATE, sd_STATE, residual_STATE, recursive_STATE, in_fit,
// mode_fitted).
py::dict FitTraceDict(const Model& model, const SampleData& data, const std::vector<int>& measured,
                      const FittedOutputs& outputs) {
  const auto K = static_cast<long>(data.t.size());
  const auto size = static_cast<std::size_t>(K);
  const std::vector<long> chains = ChainNumbers(data);
  std::vector<double> run(size), chain(size), missing(size, 0.0), cells(size);
  for (std::size_t k = 0; k < std::size_t(K); ++k) {
    run[k] = k < data.run.size() ? data.run[k] + 1.0 : 1.0;
    chain[k] = static_cast<double>(chains[k]);
  }
  py::dict out;
  out["run"] = py::array_t<double>(py::ssize_t(K), run.data());
  out["chain"] = py::array_t<double>(py::ssize_t(K), chain.data());
  out["t"] = py::array_t<double>(py::ssize_t(K), data.t.data());
  out["missing"] = py::array_t<double>(py::ssize_t(K), missing.data());
  out["measured"] = data.y.rows() == static_cast<Eigen::Index>(measured.size())
                        ? Transposed(data.y)
                        : Transposed(Mat(data.y(measured, Eigen::all)));
  for (const FitColumn& c : FitColumns(model.spec(), measured, data.y, outputs)) {
    for (long k = 0; k < K; ++k) cells[std::size_t(k)] = c.cell(k);
    out[py::str(c.name)] = py::array_t<double>(py::ssize_t(K), cells.data());
  }
  return out;
}

bool IsList(const py::handle& o) { return py::isinstance<py::list>(o) || py::isinstance<py::tuple>(o); }

// y is a list of runs when it is a list or tuple that is not one run's rows (a 2-D array of numbers).
bool IsRuns(const py::handle& y) {
  if (!IsList(y)) return false;
  try {
    return py::module_::import("numpy").attr("asarray")(y).cast<py::array>().ndim() != 2;
  } catch (const py::error_already_set& e) {
    if (!IsValueError(e)) throw;  // KeyboardInterrupt (Ctrl-C during the conversion) and the like
    return true;                  // ragged: arrays of different lengths, one per run
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

// One run's inputs, aligned with its K samples, as m × K: a (K, m) array (or (K,) for one input), or
// a dict input name -> K values.
Mat InputSamples(const py::handle& u, const ModelSpec& spec, Eigen::Index k, const std::string& what) {
  const int m = static_cast<int>(spec.inputs.size());
  Mat out(m, k);
  if (py::isinstance<py::dict>(u)) {
    const py::dict d = py::reinterpret_borrow<py::dict>(u);
    for (const auto& [key, column] : d) {
      const std::string name = Text(key, what);
      if (std::find(spec.inputs.begin(), spec.inputs.end(), name) == spec.inputs.end()) {
        throw std::invalid_argument(fmt::format("{}: '{}' is not an input of model '{}' (inputs: {})", what, name,
                                                spec.name, fmt::join(spec.inputs, ", ")));
      }
    }
    for (int i = 0; i < m; ++i) {
      const std::string& name = spec.inputs[static_cast<std::size_t>(i)];
      if (!d.contains(name)) throw std::invalid_argument(fmt::format("{}: no values for input '{}'", what, name));
      const std::vector<double> v = Times(d[py::str(name)], fmt::format("{}['{}']", what, name));
      if (static_cast<Eigen::Index>(v.size()) != k) {
        throw std::invalid_argument(
            fmt::format("{}['{}'] has {} values; y has {} samples", what, name, v.size(), k));
      }
      out.row(i) = Eigen::Map<const Eigen::RowVectorXd>(v.data(), k);
    }
    return out;
  }
  const py::array_t<double> a = RealArray(u, what);
  if (m == 1 && a.ndim() == 1 && a.shape(0) == k) return Eigen::Map<const Mat>(a.data(), 1, k);
  if (a.ndim() != 2 || a.shape(0) != k || a.shape(1) != m) {
    throw std::invalid_argument(fmt::format("{} must be a ({}, {}) array aligned with y (inputs {}); got shape {}",
                                            what, k, m, fmt::join(spec.inputs, ", "), ShapeText(a)));
  }
  return Eigen::Map<const Mat>(a.data(), m, k);
}

// The per-run list of `value` (a list of as many as there are runs), or the one run's value.
py::object RunItem(const py::object& value, bool runs, std::size_t r, std::size_t count, const std::string& name,
                   const std::string& kind = "1-D arrays") {
  if (!runs) return value;
  if (!IsList(value) || py::len(value) != count) {
    throw std::invalid_argument(
        fmt::format("{}: y is a list of {} runs; give {} as a list of as many {}", name, count, name, kind));
  }
  return py::list(value)[r];
}

// truth['j'] of one run: the true jump counter per sample.
Eigen::RowVectorXd JumpCounter(const py::object& j, Eigen::Index k, const std::string& what) {
  const std::vector<double> v = Times(j, what);
  if (static_cast<Eigen::Index>(v.size()) != k)
    throw std::invalid_argument(fmt::format("{} has {} values; y has {} samples", what, v.size(), k));
  return Eigen::Map<const Eigen::RowVectorXd>(v.data(), k);
}

// The true jump counter as a data file's column j is read: never decreasing within a run, and the runs
// joined without a step (run r's counter continues from the last value of the runs before it).
std::vector<int> JoinedCounter(const SampleData& data, const Eigen::RowVectorXd& raw, bool runs) {
  std::vector<int> out;
  long offset = 0;
  for (Eigen::Index k = 0; k < raw.size(); ++k) {
    const auto ks = static_cast<std::size_t>(k);
    const long v = std::lround(raw[k]);
    if (k > 0 && data.run[ks] != data.run[ks - 1]) {
      offset = out.back() - v;
    } else if (k > 0 && v < std::lround(raw[k - 1])) {
      const std::string r = runs ? fmt::format("[{}]", data.run[ks]) : "";
      throw std::invalid_argument(fmt::format("truth['j']{}[{}]: {} after {}: a jump counter never decreases within a run",
                                              r, data.line[ks] - 1, v, std::lround(raw[k - 1])));
    }
    out.push_back(static_cast<int>(offset + v));
  }
  return out;
}

// y, u and truth['j'] as runs, checked as `hysid identify --data` checks its files (one table of
// columns y, u, j per run); messages name y, u, t and truth.
SampleData RunsOf(const Model& model, const IdentifyArgs& args, const py::object& y, const py::object& t, double dt) {
  const ModelSpec& spec = model.spec();
  const std::vector<int> measured = MeasuredIndices(model);
  const int ny = static_cast<int>(measured.size()), m = model.input_size();
  if (m == 0 && !args.u.is_none())
    throw std::invalid_argument(fmt::format("u: model '{}' has no inputs", spec.name));
  if (m > 0 && args.u.is_none()) {
    throw std::invalid_argument(fmt::format("u: model '{}' has measured inputs ({}): give u, aligned with y",
                                            spec.name, fmt::join(spec.inputs, ", ")));
  }
  py::object j = py::none();
  if (!args.truth.is_none()) {
    if (!py::isinstance<py::dict>(args.truth) || !args.truth.contains("j"))
      throw std::invalid_argument("truth: expected a dict with 'j' (and optionally 'x0', 'sigma')");
    j = args.truth["j"];
  }
  const bool runs = IsRuns(y);
  const py::list ys = runs ? py::list(y) : py::list(py::make_tuple(y));
  if (ys.empty()) throw std::invalid_argument("y: an empty list; give a (samples, n) array, or a list of runs");
  std::vector<Mat> columns;
  std::vector<std::vector<double>> times(ys.size());
  for (std::size_t r = 0; r < ys.size(); ++r) {
    const std::string at = runs ? fmt::format("[{}]", r) : "";
    const Mat yr = Samples(ys[r], ny, "y" + at);
    Mat table(ny + m + (j.is_none() ? 0 : 1), yr.cols());
    table.topRows(ny) = yr;
    if (m > 0) table.middleRows(ny, m) = InputSamples(RunItem(args.u, runs, r, ys.size(), "u", "arrays or dicts"), spec, yr.cols(), "u" + at);
    if (!j.is_none()) table.bottomRows(1) = JumpCounter(RunItem(j, runs, r, ys.size(), "truth['j']"), yr.cols(), "truth['j']" + at);
    columns.push_back(std::move(table));
  }
  if (!t.is_none()) {
    for (std::size_t r = 0; r < ys.size(); ++r)
      times[r] = Times(RunItem(t, runs, r, ys.size(), "t"), runs ? fmt::format("t[{}]", r) : "t");
  }
  SampleData data;
  try {  // its checks and copies take a while on large arrays: on a thread, Ctrl-C answered meanwhile
    const auto arrays = std::make_shared<const std::pair<std::vector<std::vector<double>>, std::vector<Mat>>>(
        std::move(times), std::move(columns));
    const double max_gap = args.max_gap.value_or(0.0);
    data = RunInterruptible<SampleData>(
        [arrays, dt, max_gap] { return SampleDataFromArrays(arrays->first, arrays->second, dt, {.max_gap = max_gap}); });
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(ArrayMessage(e.what(), runs, ny, m));
  }
  if (!j.is_none()) data.j = JoinedCounter(data, data.y.row(ny + m), runs);
  data.u = data.y.middleRows(ny, m);
  const Mat states = data.y.topRows(ny);
  data.y = states;
  data.state_columns.clear();
  for (const int i : measured) data.state_columns.push_back(spec.state_names[static_cast<std::size_t>(i)]);
  data.input_columns = spec.inputs;
  return data;
}

// y, t, dt (and args.u) as runs with the checks of `hysid identify --data` (sample count and limit, time
// steps), t and dt agreeing when both are given; one run on the grid k·dt with no sample missing takes
// the grid's own dt (*grid set).
SampleData ArrayData(const Model& model, const IdentifyArgs& args, const py::object& y, const py::object& t,
                     std::optional<double> dt, bool* grid) {
  SampleData data = RunsOf(model, args, y, t, dt.value_or(0.0));
  if (dt && !t.is_none() && !(std::abs(data.dt - *dt) <= 1e-6 * *dt)) {
    throw std::invalid_argument(fmt::format("dt = {}: t has {} step {}; give dt or t, or both that agree",
                                            *dt, data.uniform ? "the" : "the median", data.dt));
  }
  *grid = t.is_none() && !args.max_gap && !IsRuns(y) && static_cast<std::size_t>(data.y.cols()) == py::len(y);
  if (*grid) data.dt = *dt;
  return data;
}

// The truth's x0 and sigma (one value, or one per state) for the CRLB at the truth; none unless both
// are given and the data are one uniform run (as the command line's sidecar).
Truth TruthOf(const IdentifyArgs& args, const Model& model, const SampleData& data) {
  if (args.truth.is_none() || !data.uniform || !args.truth.contains("x0") || !args.truth.contains("sigma")) return {};
  const int n = model.state_size();
  const std::vector<double> x0 = Numbers(args.truth["x0"], "truth['x0']");
  if (static_cast<int>(x0.size()) != n)
    throw std::invalid_argument(fmt::format("truth['x0'] has {} values; model '{}' has {} states", x0.size(), model.name(), n));
  return {Eigen::Map<const Vec>(x0.data(), n),
          CheckedSigma(Numbers(args.truth["sigma"], "truth['sigma']"), n, /*allow_zero=*/true, Spelling::kKeyword)};
}


// The outcome and its report, made on the computation's thread.
struct Fit {
  IdentifyOutcome outcome;
  nlohmann::json report;
};

py::dict Identify(const py::object& model_arg, const py::object& y, const py::object& dt_arg,
                  const py::object& t, const py::kwargs& kwargs) {
  IdentifyArgs args = ParseKeywords(kwargs, ModelArgument(model_arg).model);
  IdentifyRequest& request = args.request;
  Model& model = request.model;
  const std::optional<double> dt = OptionalNumber(dt_arg, "dt");
  if (dt && (!(*dt > 0.0) || !std::isfinite(*dt)))
    throw std::invalid_argument(fmt::format("dt = {}: must be > 0", *dt));
  if (args.max_gap) CheckMaxGap(*args.max_gap, fmt::format("{}", *args.max_gap), Spelling::kKeyword);
  if (t.is_none() && !dt) throw std::invalid_argument("dt: required when t is not given");
  ApplyBounds(args.bounds, Spelling::kKeyword, &model);
  CheckRequest(request);
  bool grid = false;
  request.data = ArrayData(model, args, y, t, dt, &grid);
  SampleData& data = request.data;
  CheckRequestData(request);
  request.truth = TruthOf(args, model, data);
  const bool refine = request.refine == "ml", chains = !data.uniform;
  auto stop = std::make_shared<std::atomic<bool>>(false);
  const Fit f = RunInterruptible<Fit>(
      [request, stop] {
        IdentifyRequest r = request;
        r.stop = stop.get();
        IdentifyOutcome outcome = RunIdentification(std::move(r));
        nlohmann::json report = OutcomeJson(outcome);
        return Fit{std::move(outcome), std::move(report)};
      },
      stop);
  py::dict out = FitDict(model, f.outcome, f.report, request.trace, refine, chains);
  out["report"] = FromJson(f.report);
  out["fit_trace"] = FitTraceDict(model, data, MeasuredIndices(model), f.outcome.refinement.outputs);
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
      "same checks and messages). y: (samples, measured states) at spacing dt, or at times t (one per "
      "sample): the columns of Model.measured (every state unless the model says otherwise; the others "
      "are reconstructed as a start and the refinement fits the measured ones); u: the measured inputs "
      "aligned with y (a model with inputs); a list of such arrays (and of times and inputs) is several runs "
      "of one system (alpha, beta shared). A row with a NaN is left out (an infinite value is refused) and "
      "restarts the chain, as does a step longer than max_gap. An unknown keyword, and an option the chosen "
      "detector or estimator does not read, is refused.\n\n"
      "Returns a dict: alpha, beta (full vectors), estimates (the unknowns by name), gamma, statistic, "
      "threshold, alpha_trace, beta_trace, jumps_detected, flow_status (`inconsistent` when the recursive "
      "estimate contradicts its data: docs/method.md), jump_status, flow_reason, jump_reason, flow_hull, "
      "jump_hull, sets_skipped, notes (an estimate 100 times or more from its start value: \"check the "
      "units\"; a recursive estimate outside the model's bounds: \"lies outside its bounds\"); with refine='ml' also refined (the keys of "
      "`hysid identify --json`: status, reason, names, estimates, recursive_estimates, standard_errors, "
      "covariance, alpha, beta, x0, sigma, sigma_estimated, normalized_rms, lag1, iterations, samples_used, "
      "span_reason, model_jumps, start_repair, mended, start; with runs or times also chain_x0, "
      "chain_samples_used, chain_span_reason, chains_used, chains_skipped, gaps_joined). With t, runs, NaN rows or "
      "max_gap the per-sample arrays are over the samples used, listed in t and run, with chains and "
      "missing_rows. report: what `hysid identify --json` writes, key for key (docs/outputs.md: settings, "
      "data, detections with their times, chains, truth with truth=, crlb, checks, measured, "
      "reconstructed, fitted_events, ...). fit_trace: per sample what `hysid identify --trace` adds after "
      "the refinement (run, chain, t, missing, measured, fit_STATE, sd_STATE, residual_STATE, "
      "recursive_STATE, in_fit, mode_fitted), read by hysid_plots.fit.plot_fit(result). Ctrl-C raises "
      "KeyboardInterrupt and stops the refinement.\n\nKeywords:\n";
  for (const IdentifySetting& s : IdentifySettings()) {
    doc += fmt::format("  {} = {}: {}\n", Spelled(s.name, Spelling::kKeyword), s.keyword.default_text,
                       SettingHelp(s, Spelling::kKeyword));
  }
  for (const Keyword& k : PythonKeywords()) doc += fmt::format("  {} = {}: {}\n", k.name, k.default_text, k.help);
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

SampleData SamplesFromArrays(const Model& model, const py::object& y, const py::object& t, const py::object& dt_arg,
                             const py::object& u) {
  const std::optional<double> dt = OptionalNumber(dt_arg, "dt");
  if (dt && (!(*dt > 0.0) || !std::isfinite(*dt)))
    throw std::invalid_argument(fmt::format("dt = {}: must be > 0", *dt));
  if (t.is_none() && !dt) throw std::invalid_argument("dt: required when t is not given");
  IdentifyArgs args(model);
  args.u = u;
  bool grid = false;
  return ArrayData(model, args, y, t, dt, &grid);
}

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
