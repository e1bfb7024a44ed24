// hysid.identify: every option of `hysid identify` as a keyword. The detector's and the estimators'
// options come from their tables (PluginOptionArguments, experiments/cli/checks.hpp: the same list
// the command line builds its flags from), with their help texts and defaults in the docstring.
#include <pybind11/stl.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <algorithm>
#include <atomic>
#include <map>
#include <memory>
#include <regex>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/identify/identifier.hpp"
#include "core/identify/reconstruct.hpp"
#include "core/io/sample_data.hpp"
#include "experiments/cli/checks.hpp"
#include "experiments/cli/cli.hpp"
#include "experiments/cli/identify_output.hpp"
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
       "known measurement noise sigma > 0 (one number, or one per state); None: estimated where needed"},
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
      {"u", "None",
       "a model with inputs: the measured inputs, aligned with y: a (samples, inputs) array, or a dict input "
       "name -> one value per sample (a list of those for runs)"},
      {"x0_known", "None",
       "the components of x0 that are known (held at x0 in the refinement): True or 'all' for every one, "
       "or state names (a list, or comma-separated); one chain only"},
      {"x0", "None", "with x0_known: the initial state (one value per state; default: the model's)"},
      {"param_bound", "None", "bounds of unknown parameters in the refinement: {name: (lo, hi)}"},
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
  py::object u = py::none(), truth = py::none();
  std::optional<std::string> x0_known;  // as --x0-known's text
  std::vector<double> x0;
  std::vector<std::string> bounds;  // as --param-bound's values, NAME=LO,HI
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
    } else if (name == "u" || name == "truth") {
      (name == "u" ? a.u : a.truth) = py::reinterpret_borrow<py::object>(value);
    } else if (name == "x0_known") {
      a.x0_known = X0KnownText(value);
    } else if (name == "x0") {
      a.x0 = Numbers(value, name);
    } else if (name == "param_bound") {
      a.bounds = BoundTexts(value);
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
  if (const std::string problem = RefineChoiceProblem(a.refine); !problem.empty())
    throw std::invalid_argument("refine: " + problem);
  CheckBoundsNeedRefinement(!a.bounds.empty(), a.refine, Spelling::kKeyword);
  return a;
}

// The identifier's settings, checked as `hysid identify` checks its flags, with the same messages.
IdentifierSettings Settings(const IdentifyArgs& a, const Model& model) {
  IdentifierSettings s;
  SetPluginKinds(a.estimator, a.detector, Spelling::kKeyword, &s);
  ApplyPluginOptions(a.options, Spelling::kKeyword, &s);
  s.flow_estimator.noise_shape = a.flow_shape;
  s.jump_estimator.noise_shape = a.jump_shape;
  CheckNoiseShapesUsed(s, a.flow_shape.size() > 0, a.jump_shape.size() > 0, Spelling::kKeyword);
  CheckDataAccuracy(a.data_rtol, a.data_atol, Spelling::kKeyword);
  s.localize = a.localize;
  s.second_pass = a.second_pass;
  s.sets = a.sets;
  if (!a.sigma.empty() && static_cast<int>(MeasuredIndices(model).size()) == model.state_size())
    s.sigma = CheckedSigma(a.sigma, model.state_size(), /*allow_zero=*/false, Spelling::kKeyword);
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

// What `hysid identify` computes (RunIdentify, experiments/cli/identify.cpp): the reconstruction of
// unmeasured states, the recursive pass, the refinement and the --json report.
struct FitOutcome {
  IdentifyResult recursive;
  cli::PartialOutputs partial;
  cli::RefineStep step;
  nlohmann::json report;
};

// --refine, --x0-known and --x0 as RefineArgs (the App that holds --x0-known's option with them).
struct RefineFlags {
  std::shared_ptr<X0KnownKeyword> known;
  cli::RefineArgs args;
};

RefineFlags MakeRefineFlags(const IdentifyArgs& a) {
  RefineFlags f{MakeX0Known(a.x0_known), {}};
  f.args.refine = a.refine;
  f.args.x0.x0 = a.x0;
  f.args.x0_known = f.known->flag;
  return f;
}

// Everything a fit reads, owned (it runs on its own thread: RunInterruptible).
struct FitJob {
  explicit FitJob(Model m) : model(std::move(m)) {}
  Model model;
  SampleData data;
  IdentifierSettings settings;
  Vec sigma;  // per measured state, or empty
  std::vector<int> measured;
  RefineFlags flags;
  cli::Truth truth;
  std::string accuracy_source;
  bool trace = true;
};

FitOutcome RunFit(FitJob job, const std::atomic<bool>* stop) {
  IdentifyOptions options{.trace = job.trace, .stop = stop};
  if (!job.data.uniform) {
    options.times = job.data.t;
    options.chain_start = job.data.chain_start;
  }
  options.inputs = job.data.u;
  std::vector<double> kinks;
  FitOutcome out;
  out.partial = cli::Reconstruct(job.model, "", job.measured, job.sigma, job.data, options, &kinks);
  out.recursive = hysid::Identify(job.model, job.data.y, job.data.dt, job.settings, options);
  if (!out.partial.reconstructed.empty()) {  // the detector's statistic is the kinks'
    out.recursive.statistic = kinks;
    out.recursive.threshold.assign(kinks.size(), ReconstructOptions{}.kink_threshold);
  }
  const nlohmann::json report =
      cli::RecursiveJson(job.model, job.data, job.settings, job.accuracy_source, out.recursive);
  out.step = cli::RunRefineStep(job.model, job.data, out.recursive, job.sigma, job.flags.args, out.partial,
                                job.truth, stop);
  out.report = cli::RefineJson(job.model, job.data, out.recursive, job.flags.args, report, out.partial, out.step);
  return out;
}

// The refinement's dict: the keys of `hysid identify --json` (names, sigma, normalized_rms, lag1,
// iterations, ...), the estimates also by name.
py::dict RefinedDict(const RefineResult& r, const IdentifyResult& given, bool chains) {
  py::dict out;
  out["status"] = ToString(r.status);
  out["reason"] = r.reason;
  out["route"] = r.route;
  out["routes_tried"] = r.routes_tried;
  out["reported"] = r.reported;
  out["names"] = r.names;
  out["estimates"] = ByName(r.names, r.estimate.Theta(r.unknowns));
  out["recursive_estimates"] = ByName(r.names, r.start.Theta(r.unknowns));
  out["standard_errors"] = ByName(r.names, r.standard_errors);  // empty unless reported
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
  out["mended"] = r.mended;  // detections mended, or the route that reached the fit ("" when none)
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

py::dict FitDict(const Model& model, const FitOutcome& f, bool trace, bool refine, bool chains) {
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
  if (refine) out["refined"] = RefinedDict(f.step.result, r, chains);
  out["notes"] = f.step.notes;  // an estimate far from its start value: "check the units"
  return out;
}

// What a fit figure reads, as `hysid identify --trace` has it per sample (hysid_plots.fit.plot_fit):
// run, chain, t, missing (0: the samples), the measured samples (samples, measured states) and the
// fitted model's columns (cli::FitColumns: fit_STATE, sd_STATE, residual_STATE, recursive_STATE, in_fit,
// mode_fitted).
py::dict FitTraceDict(const Model& model, const SampleData& data, const std::vector<int>& measured,
                      const FitOutcome& f) {
  const auto K = static_cast<long>(data.t.size());
  const auto size = static_cast<std::size_t>(K);
  const std::vector<long> chains = cli::ChainNumbers(data);
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
  for (const cli::FitColumn& c : cli::FitColumns(model.spec(), measured, data.y, f.step.outputs)) {
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

// The truth's x0 and sigma (one value, or one per state) for the CRLB at the truth; none unless both
// are given and the data are one uniform run (as the command line's sidecar).
cli::Truth TruthOf(const IdentifyArgs& args, const Model& model, const SampleData& data) {
  if (args.truth.is_none() || !data.uniform || !args.truth.contains("x0") || !args.truth.contains("sigma")) return {};
  const int n = model.state_size();
  const std::vector<double> x0 = Numbers(args.truth["x0"], "truth['x0']");
  if (static_cast<int>(x0.size()) != n)
    throw std::invalid_argument(fmt::format("truth['x0'] has {} values; model '{}' has {} states", x0.size(), model.name(), n));
  return {Eigen::Map<const Vec>(x0.data(), n),
          CheckedSigma(Numbers(args.truth["sigma"], "truth['sigma']"), n, /*allow_zero=*/true, Spelling::kKeyword)};
}

py::object FromJson(const nlohmann::json& j) { return py::module_::import("json").attr("loads")(j.dump()); }

py::dict Identify(const py::object& model_arg, const py::object& y, const py::object& dt_arg,
                  const py::object& t, const py::kwargs& kwargs) {
  Model model = ModelArgument(model_arg).model;
  const IdentifyArgs args = ParseKeywords(kwargs);
  const std::optional<double> dt = OptionalNumber(dt_arg, "dt");
  if (dt && (!(*dt > 0.0) || !std::isfinite(*dt)))
    throw std::invalid_argument(fmt::format("dt = {}: must be > 0", *dt));
  if (args.max_gap && (!(*args.max_gap > 0.0) || !std::isfinite(*args.max_gap))) {
    throw std::invalid_argument(fmt::format("max_gap = {}: must be a number > 0 (seconds)", *args.max_gap));
  }
  if (t.is_none() && !dt) throw std::invalid_argument("dt: required when t is not given");
  Keyworded([&] { cli::ApplyBoundFlags(args.bounds, &model); });
  FitJob job(model);
  job.settings = Settings(args, model);
  job.measured = MeasuredIndices(model);
  if (!args.sigma.empty())
    job.sigma = CheckedSigma(args.sigma, static_cast<int>(job.measured.size()), /*allow_zero=*/false,
                             Spelling::kKeyword);
  CheckSigmaRange(job.sigma, Spelling::kKeyword);
  // The checks of `hysid identify --data` (sample count and limit, time steps), on every path.
  job.data = RunsOf(model, args, y, t, dt.value_or(0.0));
  if (dt && !t.is_none() && !(std::abs(job.data.dt - *dt) <= 1e-6 * *dt)) {
    throw std::invalid_argument(fmt::format("dt = {}: t has {} step {}; give dt or t, or both that agree",
                                            *dt, job.data.uniform ? "the" : "the median", job.data.dt));
  }
  const bool grid = t.is_none() && !args.max_gap && !IsRuns(y) &&
                    static_cast<std::size_t>(job.data.y.cols()) == py::len(y);
  if (grid) job.data.dt = *dt;  // one run on the grid k·dt, no sample missing: the grid's own dt
  job.flags = MakeRefineFlags(args);
  Keyworded([&] { cli::CheckRefineArgs(job.flags.args, model, job.data); });
  job.truth = TruthOf(args, model, job.data);
  job.accuracy_source = kwargs.contains("data_rtol") || kwargs.contains("data_atol") ? "as given" : "none given";
  job.trace = args.trace;
  const bool refine = args.refine == "ml", chains = !job.data.uniform;
  auto stop = std::make_shared<std::atomic<bool>>(false);
  const FitOutcome f =
      RunInterruptible<FitOutcome>([job, stop] { return RunFit(job, stop.get()); }, stop);
  py::dict out = FitDict(model, f, args.trace, refine, chains);
  out["report"] = FromJson(f.report);
  out["fit_trace"] =
      FitTraceDict(model, job.data, f.partial.measured.empty() ? job.measured : f.partial.measured, f);
  if (!grid) {
    out["t"] = py::array_t<double>(py::ssize_t(job.data.t.size()), job.data.t.data());
    out["run"] = py::array_t<int>(py::ssize_t(job.data.run.size()), job.data.run.data());
    out["chains"] = job.data.chains();
    out["missing_rows"] = job.data.missing_rows;
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
      "chain_samples_used, chain_span_reason, chains_used, chains_skipped). With t, runs, NaN rows or "
      "max_gap the per-sample arrays are over the samples used, listed in t and run, with chains and "
      "missing_rows. report: what `hysid identify --json` writes, key for key (docs/outputs.md: settings, "
      "data, detections with their times, chains, truth with truth=, crlb, checks, measured, "
      "reconstructed, fitted_events, ...). fit_trace: per sample what `hysid identify --trace` adds after "
      "the refinement (run, chain, t, missing, measured, fit_STATE, sd_STATE, residual_STATE, "
      "recursive_STATE, in_fit, mode_fitted), read by hysid_plots.fit.plot_fit(result). Ctrl-C raises "
      "KeyboardInterrupt and stops the refinement.\n\nKeywords:\n";
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
