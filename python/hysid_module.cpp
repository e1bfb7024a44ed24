// The `hysid` Python module: models (built-in names or model files), simulate, identify, the
// Cramér–Rao bound and sweeps, calling the same C++ as the command line. NumPy arrays in and out; samples are
// rows (K × n). No Python code runs per sample, and the GIL is released while C++ computes.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <future>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/builtin/builtin.hpp"
#include "core/identify/identifier.hpp"
#include "core/io/sample_data.hpp"
#include "core/model/registry.hpp"
#include "experiments/cli/checks.hpp"
#include "experiments/sweep/config.hpp"
#include "experiments/sweep/runner.hpp"
#include "sim/measurement.hpp"
#include "sim/model_check/model_check.hpp"
#include "sim/refine/refine.hpp"
#include "sim/sensitivity/crlb.hpp"
#include "sim/simulator.hpp"

namespace py = pybind11;

namespace hysid {
namespace {

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using InArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

const ModelRegistry& Builtins() {
  static const ModelRegistry registry = [] {
    ModelRegistry r;
    RegisterBuiltinModels(r);
    return r;
  }();
  return registry;
}

// A registered name, or a model file (a path that exists).
Model MakeModel(const std::string& name_or_file) {
  if (Builtins().Contains(name_or_file)) return Builtins().Make(name_or_file);
  if (std::filesystem::exists(name_or_file)) return LoadModelFile(name_or_file);
  throw std::invalid_argument(fmt::format("'{}' is neither a built-in model nor a model file", name_or_file));
}

// A matrix stored column-major as rows × cols, returned with one row per column (K × rows).
py::array_t<double> Transposed(const Mat& m) {
  py::array_t<double> out({m.cols(), m.rows()});
  if (m.size()) std::memcpy(out.mutable_data(), m.data(), sizeof(double) * std::size_t(m.size()));
  return out;
}

py::array_t<double> ToArray(const Vec& v) {
  py::array_t<double> out(v.size());
  if (v.size()) std::memcpy(out.mutable_data(), v.data(), sizeof(double) * std::size_t(v.size()));
  return out;
}

// A number or a sequence of numbers as a list (empty when `value` is None).
std::vector<double> Values(const py::object& value) {
  if (value.is_none()) return {};
  return py::isinstance<py::sequence>(value) ? value.cast<std::vector<double>>()
                                             : std::vector<double>{value.cast<double>()};
}

// σ checked as the command line's --sigma (experiments/cli/checks.hpp); empty when `value` is None.
Vec SigmaArgument(const py::object& value, int n, bool allow_zero) {
  if (value.is_none()) return {};
  return CheckedSigma(Values(value), n, allow_zero, Spelling::kKeyword);
}

// The start state (x0 or the model's), the sample grid (t_end, dt or the model's) and the solver
// options of a simulation, checked; errors name the argument.
struct Run {
  Vec x0;
  SampleGrid grid;
  SimOptions sim;
};

Run CheckedRun(const Model& model, const std::optional<std::vector<double>>& x0, std::optional<double> t_end,
               std::optional<double> dt, double rtol, double atol) {
  const ModelSpec& spec = model.spec();
  const int n = model.state_size();
  const std::vector<double> start = x0.value_or(spec.default_x0);
  if (static_cast<int>(start.size()) != n) {
    throw std::invalid_argument(
        fmt::format("x0 has {} values; model '{}' has {} states", start.size(), spec.name, n));
  }
  CheckFinite("x0", start);
  Run run{Eigen::Map<const Vec>(start.data(), n),
          CheckedGrid(t_end.value_or(spec.default_t_end), dt.value_or(spec.default_dt), Spelling::kKeyword),
          SimOptions{}};
  run.sim.rtol = rtol;
  run.sim.atol = atol;
  if (std::string e; !run.sim.IsValid(&e)) throw std::invalid_argument(fmt::format("rtol/atol: {}", e));
  return run;
}

py::dict SimulateDict(const Model& model, std::optional<std::vector<double>> x0, std::optional<double> t_end,
                      std::optional<double> dt, const py::object& sigma, std::uint64_t seed,
                      std::uint64_t trial, double rtol, double atol) {
  const int n = model.state_size();
  const Run run = CheckedRun(model, x0, t_end, dt, rtol, atol);
  Vec s = SigmaArgument(sigma, n, /*allow_zero=*/true);
  if (s.size() == 0) s = Vec::Zero(n);
  Trajectory traj;
  Mat y;
  {
    py::gil_scoped_release release;
    traj = hysid::Simulate(model, run.x0, run.grid, run.sim);
    y = AddMeasurementNoise(traj.x, s, NoiseKey{.seed = seed, .stream = trial});
  }
  py::list jumps;
  for (const JumpRecord& j : traj.jumps) {
    jumps.append(py::dict(py::arg("j") = j.j, py::arg("t") = j.t, py::arg("guard") = j.guard,
                          py::arg("pre") = ToArray(j.pre), py::arg("post") = ToArray(j.post)));
  }
  py::dict out;
  out["t"] = py::array_t<double>(py::ssize_t(traj.t.size()), traj.t.data());
  out["j"] = py::array_t<int>(py::ssize_t(traj.j.size()), traj.j.data());
  out["x"] = Transposed(traj.x);
  out["y"] = Transposed(y);
  out["dt"] = run.grid.dt;
  out["jumps"] = jumps;
  out["status"] = ToString(traj.status.stop);
  out["message"] = traj.status.message;
  return out;
}

struct IdentifyArgs {
  std::string estimator = "rls", detector = "residual";
  // The plugin options given (not None), by keyword, as text: the command line's flags.
  std::map<std::string, std::string> options;
  double data_rtol = 0.0, data_atol = 0.0;
  bool localize = false, second_pass = false, sets = true, trace = true;
  std::string refine = "ml";  // "none": the recursive (paper-method) estimate only
};

// The identifier's settings, checked as `hysid identify` checks its flags.
IdentifierSettings Settings(const IdentifyArgs& a, const Vec& sigma) {
  IdentifierSettings s;
  SetPluginKinds(a.estimator, a.detector, Spelling::kKeyword, &s);
  ApplyPluginOptions(a.options, Spelling::kKeyword, &s);
  CheckDataAccuracy(a.data_rtol, a.data_atol, Spelling::kKeyword);
  s.localize = a.localize;
  s.second_pass = a.second_pass;
  s.sets = a.sets;
  s.sigma = sigma;
  s.data_rtol = a.data_rtol;
  s.data_atol = a.data_atol;
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

// The maximum-likelihood refinement of a recursive run, as `hysid identify --refine ml`: the samples at
// k·dt, or at the times and in the chains of `chains`.
// From RefinementStart(given): the rls re-run when the α estimator was not ok.
py::dict Refined(const Model& model, const Mat& y, double dt, const IdentifyResult& given,
                 const Vec& sigma, const SampleData* chains) {
  const IdentifyResult& recursive = RefinementStart(given);
  RefineOptions options;
  options.sigma = sigma;
  RefineResult r;
  {
    py::gil_scoped_release release;
    std::vector<double> t(static_cast<std::size_t>(y.cols()));
    for (std::size_t k = 0; k < t.size(); ++k) t[k] = chains ? chains->t[k] : static_cast<double>(k) * dt;
    r = RefineIdentification(model, t, y, chains ? chains->chain_start : std::vector<std::uint8_t>{},
                             recursive, options);
  }
  py::dict out, estimates, errors;
  const Vec theta = r.estimate.Theta(r.unknowns);
  for (std::size_t i = 0; i < r.names.size(); ++i) {
    estimates[py::str(r.names[i])] = theta[Eigen::Index(i)];
    if (r.standard_errors.size()) errors[py::str(r.names[i])] = r.standard_errors[Eigen::Index(i)];
  }
  out["status"] = ToString(r.status);
  out["reason"] = r.reason;
  out["mended"] = r.mended;  // detections mended from the fitted model ("" when none)
  out["start"] = given.safe_start ? given.safe_start_reason : std::string("the recursive estimate");
  out["estimates"] = estimates;
  out["standard_errors"] = errors;  // empty unless the fit is ok
  out["covariance"] = Transposed(r.covariance);
  out["alpha"] = ToArray(r.estimate.alpha);
  out["beta"] = ToArray(r.estimate.beta);
  out["x0"] = ToArray(r.estimate.x0);
  if (chains != nullptr) {
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

// The identifier on n × K samples; `chains` (irregular times, several runs, missing samples) gives
// each sample pair its own step and restarts the chains.
py::dict Fit(const Model& model, const Mat& samples, double dt, const IdentifyArgs& args,
             const py::object& sigma, const SampleData* chains) {
  const IdentifierSettings settings = Settings(args, SigmaArgument(sigma, model.state_size(), true));
  IdentifyOptions options{.trace = args.trace};
  if (chains != nullptr) {
    options.times = chains->t;
    options.chain_start = chains->chain_start;
  }
  IdentifyResult r;
  {
    py::gil_scoped_release release;
    r = hysid::Identify(model, samples, dt, settings, options);
  }
  const ModelSpec& spec = model.spec();
  py::dict out;
  out["alpha"] = ToArray(r.alpha_hat);
  out["beta"] = ToArray(r.beta_hat);
  out["estimates"] = Unknowns(spec.alpha, r.alpha_hat);
  for (auto [k, v] : Unknowns(spec.beta, r.beta_hat)) out["estimates"][k] = v;
  out["gamma"] = py::array_t<std::uint8_t>(py::ssize_t(r.gamma.size()), r.gamma.data());
  out["statistic"] = py::array_t<double>(py::ssize_t(r.statistic.size()), r.statistic.data());
  out["threshold"] = py::array_t<double>(py::ssize_t(r.threshold.size()), r.threshold.data());
  if (args.trace) {
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
  if (args.refine == "ml") {
    out["refined"] = Refined(model, samples, dt, r, settings.sigma, chains);
  } else if (args.refine != "none") {
    throw std::invalid_argument(fmt::format("refine = '{}': expected 'none' or 'ml'", args.refine));
  }
  return out;
}

// A (samples, n) array as n × K.
Mat Samples(const py::object& y, int n, const std::string& what) {
  const InArray a = py::cast<InArray>(y);
  if (a.ndim() != 2 || a.shape(1) != n) {
    throw std::invalid_argument(
        fmt::format("{} must be a (samples, {}) array, one row per sample; got shape ({})", what, n,
                    fmt::join(std::vector<py::ssize_t>(a.shape(), a.shape() + a.ndim()), ", ")));
  }
  return Eigen::Map<const Mat>(a.data(), n, a.shape(0));  // row-major K × n = n × K
}

bool IsList(const py::object& o) { return py::isinstance<py::list>(o) || py::isinstance<py::tuple>(o); }

// y and t as runs: one array, or a list of arrays (one per run); t None: k·dt.
SampleData RunsOf(const Model& model, const py::object& y, const py::object& t, double dt, double max_gap) {
  const py::list ys = IsList(y) ? py::list(y) : py::list(py::make_tuple(y));
  std::vector<Mat> runs;
  std::vector<std::vector<double>> times(ys.size());
  for (std::size_t r = 0; r < ys.size(); ++r) {
    runs.push_back(Samples(ys[r], model.state_size(), ys.size() > 1 ? fmt::format("y[{}]", r) : "y"));
  }
  if (!t.is_none()) {
    const py::list ts = IsList(t) ? py::list(t) : py::list(py::make_tuple(t));
    if (ts.size() != ys.size()) {
      throw std::invalid_argument(fmt::format("t has {} runs; y has {}", ts.size(), ys.size()));
    }
    for (std::size_t r = 0; r < ts.size(); ++r) times[r] = py::cast<std::vector<double>>(ts[r]);
  }
  py::gil_scoped_release release;
  return SampleDataFromArrays(times, runs, dt, {.max_gap = max_gap});
}

py::dict Identify(const Model& model, const py::object& y, std::optional<double> dt, const py::object& t,
                  std::optional<double> max_gap, const IdentifyArgs& args, const py::object& sigma) {
  if (dt && (!(*dt > 0.0) || !std::isfinite(*dt)))
    throw std::invalid_argument(fmt::format("dt = {}: must be > 0", *dt));
  if (max_gap && (!(*max_gap > 0.0) || !std::isfinite(*max_gap))) {
    throw std::invalid_argument(fmt::format("max_gap = {}: must be a number > 0 (seconds)", *max_gap));
  }
  if (!IsList(y) && t.is_none() && !dt) throw std::invalid_argument("dt: required when t is not given");
  // The checks of `hysid identify --data` (sample count and limit, time steps), on every path.
  const SampleData data = RunsOf(model, y, t, dt.value_or(0.0), max_gap.value_or(0.0));
  if (!IsList(y) && t.is_none() && !max_gap) {  // one run on a uniform grid
    const Mat samples = Samples(y, model.state_size(), "y");
    if (samples.allFinite()) return Fit(model, samples, *dt, args, sigma, nullptr);
  }
  py::dict out = Fit(model, data.y, data.dt, args, sigma, data.uniform ? nullptr : &data);
  out["t"] = py::array_t<double>(py::ssize_t(data.t.size()), data.t.data());
  out["run"] = py::array_t<int>(py::ssize_t(data.run.size()), data.run.data());
  out["chains"] = data.chains();
  out["missing_rows"] = data.missing_rows;
  return out;
}

// RunSweep on a worker thread while this (Python's) thread checks for signals every 0.1 s: Ctrl-C
// stops the sweep after the units already running (the journal keeps every finished unit; a rerun
// resumes) and raises KeyboardInterrupt.
SweepOutcome RunSweepInterruptible(const SweepConfig& config, const SweepOptions& options) {
  std::atomic<bool> stop{false};
  std::future<SweepOutcome> run =
      std::async(std::launch::async, [&] { return RunSweep(config, Builtins(), options, &stop); });
  while (true) {
    {
      py::gil_scoped_release release;
      if (run.wait_for(std::chrono::milliseconds(100)) == std::future_status::ready) return run.get();
    }
    if (PyErr_CheckSignals() != 0) {  // the handler raised (KeyboardInterrupt): stop between units
      stop.store(true);
      {
        py::gil_scoped_release release;
        run.wait();
      }
      throw py::error_already_set();
    }
  }
}

py::dict RunSweepFile(const std::filesystem::path& file, const std::string& out, int threads) {
  const SweepConfig config = ParseSweepFile(file, Builtins());
  SweepOptions options;
  options.out = out.empty() ? config.out : out;
  if (options.out.empty())
    throw std::invalid_argument(fmt::format("out: not given, and {} has no run.out", file.string()));
  if (threads < 0) throw std::invalid_argument(fmt::format("threads = {}: must be >= 0", threads));
  options.threads = threads;
  options.progress = Progress::Mode::kNone;
  const SweepOutcome o = RunSweepInterruptible(config, options);
  py::dict d;
  d["out"] = options.out.string();
  d["trials"] = o.units_shard;
  d["resumed"] = o.units_resumed;
  d["run"] = o.units_run;
  d["failed"] = o.failures;
  d["trajectories"] = o.trajectories;
  d["seconds"] = o.wall_seconds;
  return d;
}

py::dict Parameters(const Model& m) {
  py::dict d;
  for (std::size_t i = 0; i < m.spec().alpha.size(); ++i)
    d[py::str(m.spec().alpha[i].name)] = m.alpha()[Eigen::Index(i)];
  for (std::size_t i = 0; i < m.spec().beta.size(); ++i)
    d[py::str(m.spec().beta[i].name)] = m.beta()[Eigen::Index(i)];
  return d;
}

// The bound as `hysid crlb`: at the model's true α, β and x0 over the model's (or the given) grid.
py::dict CrlbDict(const Model& model, std::optional<std::vector<double>> x0, std::optional<double> t_end,
                  std::optional<double> dt, const py::object& sigma, bool x0_known, double rtol,
                  double atol) {
  const int n = model.state_size();
  const Run run = CheckedRun(model, x0, t_end, dt, rtol, atol);
  SensitivityOptions options;
  options.sim = run.sim;
  const Vec s = CheckedSigma(Values(sigma), n, /*allow_zero=*/false, Spelling::kKeyword);
  Crlb c;
  {
    py::gil_scoped_release release;
    c = ComputeCrlb(model, run.x0, run.grid, s, Unknowns::Of(model, !x0_known), options);
  }
  py::dict sd;
  for (std::size_t i = 0; i < c.names.size() && c.ok(); ++i) sd[py::str(c.names[i])] = c.sd[Eigen::Index(i)];
  py::dict out;
  out["status"] = ToString(c.status);
  out["message"] = c.message;
  out["names"] = c.names;
  out["sd"] = sd;
  out["covariance"] = Transposed(c.covariance);  // symmetric
  out["fisher"] = Transposed(c.fisher);
  out["mean_e_alpha"] = c.mean_e_alpha;
  out["mean_e_beta"] = c.mean_e_beta;
  out["jumps"] = c.jumps;
  out["samples"] = c.samples;
  return out;
}

void BindModel(py::module_& m) {
  py::class_<Model>(m, "Model", "A hybrid model: a built-in name (hysid.models()) or a model file (TOML)")
      .def(py::init(&MakeModel), py::arg("name_or_file"))
      .def_static(
          "from_file", [](const std::filesystem::path& p) { return LoadModelFile(p); }, py::arg("path"))
      .def_property_readonly("name", &Model::name)
      .def_property_readonly("description", [](const Model& x) { return x.spec().description; })
      .def_property_readonly("state_names", [](const Model& x) { return x.spec().state_names; })
      .def_property_readonly("parameters", &Parameters, "every parameter of alpha and beta by name")
      .def_property_readonly("equations", [](const Model& x) { return x.spec().equations; })
      .def_property_readonly("default_x0", [](const Model& x) { return x.spec().default_x0; })
      .def_property_readonly("default_t_end", [](const Model& x) { return x.spec().default_t_end; })
      .def_property_readonly("default_dt", [](const Model& x) { return x.spec().default_dt; })
      .def(
          "set",
          [](Model& x, const std::string& name, double v) {
            x.SetParameter(name, v);
            return x;
          },
          py::arg("name"), py::arg("value"), "sets an unknown parameter's true value; returns the model")
      .def("__repr__", [](const Model& x) { return fmt::format("hysid.Model('{}')", x.name()); });
  py::implicitly_convertible<std::string, Model>();
}

}  // namespace
}  // namespace hysid

PYBIND11_MODULE(hysid, m) {
  using namespace hysid;
  m.doc() = "Identification of hybrid dynamical systems from sampled states (the hysid C++ library)";
  py::register_exception<std::invalid_argument>(m, "InputError", PyExc_ValueError);
  BindModel(m);
  m.def(
      "models", [] { return Builtins().names(); }, "the built-in model names");
  m.def("simulate", &SimulateDict, py::arg("model"), py::arg("x0") = py::none(),
        py::arg("t_end") = py::none(), py::arg("dt") = py::none(), py::arg("sigma") = 0.0,
        py::arg("seed") = 1, py::arg("trial") = 0, py::arg("rtol") = 1e-12, py::arg("atol") = 1e-12,
        "One trajectory: dict with t, j, x and y (samples × states), dt, jumps, status, message");
  m.def(
      "identify",
      [](const Model& model, const py::object& y, std::optional<double> dt, const py::object& t,
         std::optional<double> max_gap, const std::string& estimator, const std::string& detector,
         std::optional<double> r, std::optional<double> tau0, std::optional<std::string> bound,
         std::optional<double> false_alarm, const py::object& sigma, std::optional<double> forgetting,
         std::optional<double> jump_forgetting, bool localize, bool second_pass, bool sets, bool trace,
         double data_rtol, double data_atol, const std::string& refine) {
        IdentifyArgs a{.estimator = estimator,
                       .detector = detector,
                       .options = {},
                       .data_rtol = data_rtol,
                       .data_atol = data_atol,
                       .localize = localize,
                       .second_pass = second_pass,
                       .sets = sets,
                       .trace = trace,
                       .refine = refine};
        for (const auto& [name, v] :
             {std::pair{"r", r}, std::pair{"tau0", tau0}, std::pair{"false_alarm", false_alarm},
              std::pair{"forgetting", forgetting}, std::pair{"jump_forgetting", jump_forgetting}}) {
          if (v) a.options[name] = fmt::format("{}", *v);
        }
        if (bound) a.options["bound"] = *bound;
        return Identify(model, y, dt, t, max_gap, a, sigma);
      },
      py::arg("model"), py::arg("y"), py::arg("dt") = py::none(), py::arg("t") = py::none(),
      py::arg("max_gap") = py::none(), py::arg("estimator") = "rls", py::arg("detector") = "residual",
      py::arg("r") = py::none(), py::arg("tau0") = py::none(), py::arg("bound") = py::none(),
      py::arg("false_alarm") = py::none(), py::arg("sigma") = py::none(), py::arg("forgetting") = 1.0,
      py::arg("jump_forgetting") = 1.0, py::arg("localize") = false, py::arg("second_pass") = false,
      py::arg("sets") = true, py::arg("trace") = true, py::arg("data_rtol") = 0.0, py::arg("data_atol") = 0.0,
      py::arg("refine") = "ml",
      "The identifier on samples y (checked as `hysid identify` checks its flags and data, with the same "
      "messages; r, tau0, bound, false_alarm, forgetting, jump_forgetting: None for the default, and an "
      "option the chosen detector or estimator does not read is refused). On samples y (samples × states) at "
      "spacing dt, or at times t (one per sample), as "
      "`hysid identify`; y (and t) may be lists of arrays, one per run of the system (alpha, beta shared); a "
      "row with a NaN is left out (an infinite value is refused) and restarts the chain, as does a step "
      "longer than max_gap (default 5 x the median step). Dict with alpha, beta (full vectors), estimates "
      "(the unknowns by name), gamma, statistic, "
      "threshold, alpha_trace, beta_trace, jumps_detected, flow_status, jump_status, flow_hull, jump_hull; "
      "with refine='ml' (the default, as `hysid identify`) also refined (status, reason, estimates and "
      "standard_errors by name, covariance, alpha, beta, x0; with runs or times also chain_x0, "
      "chain_samples_used, chain_span_reason); "
      "refine='none' "
      "and detector='paper' give the paper's online method. With t, runs, NaN rows or max_gap the per-sample "
      "arrays are over the samples used, listed in t and run, with chains and missing_rows");
  m.def("crlb", &CrlbDict, py::arg("model"), py::arg("x0") = py::none(), py::arg("t_end") = py::none(),
        py::arg("dt") = py::none(), py::arg("sigma") = 1.0, py::arg("x0_known") = false,
        py::arg("rtol") = SimOptions{}.rtol, py::arg("atol") = SimOptions{}.atol,
        "The Cramér–Rao lower bound as `hysid crlb`: dict with status, message, names, sd (by name), "
        "covariance, fisher, mean_e_alpha, mean_e_beta, jumps, samples");
  m.def("run_sweep", &RunSweepFile, py::arg("file"), py::arg("out") = "", py::arg("threads") = 0,
        "Runs a sweep file as `hysid sweep` (resumes from the run directory's journal); returns the counts");
}
