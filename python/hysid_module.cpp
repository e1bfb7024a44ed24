// The `hysid` Python module: models (built-in names or model files), simulate, identify, the
// Cramér–Rao bound and sweeps, calling the same C++ as the command line. NumPy arrays in and out; samples are
// rows (K × n). No Python code runs per sample; the long calls run without the GIL and Ctrl-C interrupts
// them (python/binding.hpp, RunInterruptible). identify is in python/identify.cpp.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "experiments/request/checks.hpp"
#include "experiments/sweep/config.hpp"
#include "experiments/sweep/runner.hpp"
#include "python/binding.hpp"
#include "sim/input_signal.hpp"
#include "sim/measurement.hpp"
#include "sim/sensitivity/crlb.hpp"
#include "sim/simulator.hpp"

namespace hysid::python {
namespace {

// The start state (x0 or the model's), the sample grid (t_end, dt or the model's) and the solver
// options of a simulation, checked; errors name the argument.
struct Run {
  Vec x0;
  SampleGrid grid;
  SimOptions sim;
  InputSignal inputs;  // empty for a model without inputs
};

// The inputs of a run over `grid` (keyword `inputs`): None, the model file's default expressions of t
// (as the command line without --inputs); or {'t': times, name: values, ...} (t left out: the sample
// times), linear between the given times. Empty for a model without inputs.
InputSignal InputsArgument(const py::object& value, const ModelSpec& spec, const SampleGrid& grid) {
  if (value.is_none()) return CheckedInputs("", spec, grid, Spelling::kKeyword);
  if (spec.inputs.empty()) throw std::invalid_argument(fmt::format("inputs: model '{}' has no inputs", spec.name));
  if (!py::isinstance<py::dict>(value))
    throw std::invalid_argument("inputs: expected a dict {'t': times, input name: values}");
  const py::dict d = py::reinterpret_borrow<py::dict>(value);
  for (const auto& [key, column] : d) {
    const std::string name = Text(key, "inputs");
    if (name != "t" && std::find(spec.inputs.begin(), spec.inputs.end(), name) == spec.inputs.end()) {
      throw std::invalid_argument(fmt::format("inputs: '{}' is not an input of model '{}' (inputs: {})", name,
                                              spec.name, fmt::join(spec.inputs, ", ")));
    }
  }
  InputSignal s;
  if (d.contains("t")) {
    s.times = Numbers(d["t"], "inputs['t']");
  } else {
    for (long k = 0; k < grid.size(); ++k) s.times.push_back(static_cast<double>(k) * grid.dt);
  }
  s.values.resize(static_cast<Eigen::Index>(spec.inputs.size()), static_cast<Eigen::Index>(s.times.size()));
  for (std::size_t i = 0; i < spec.inputs.size(); ++i) {
    const std::string& name = spec.inputs[i];
    if (!d.contains(name)) throw std::invalid_argument(fmt::format("inputs: no values for input '{}'", name));
    const std::vector<double> v = Numbers(d[py::str(name)], fmt::format("inputs['{}']", name));
    if (v.size() != s.times.size()) {
      throw std::invalid_argument(fmt::format("inputs['{}'] has {} values for {} times{}", name, v.size(),
                                              s.times.size(), d.contains("t") ? "" : " (the sample times)"));
    }
    s.values.row(static_cast<Eigen::Index>(i)) = Eigen::Map<const Eigen::RowVectorXd>(v.data(), Eigen::Index(v.size()));
  }
  if (const std::string e = InputSignalError(s, "inputs"); !e.empty()) throw std::invalid_argument(e);
  const double t_last = static_cast<double>(grid.size() - 1) * grid.dt;
  if (const std::string e = InputRangeError(s, spec.inputs, 0.0, t_last); !e.empty())
    throw std::invalid_argument("inputs: " + e);
  return s;
}

Run CheckedRun(const Model& model, const py::object& x0, const py::object& t_end, const py::object& dt,
               const py::object& rtol, const py::object& atol, const py::object& inputs = py::none()) {
  const ModelSpec& spec = model.spec();
  const int n = model.state_size();
  const std::vector<double> start = x0.is_none() ? spec.default_x0 : Numbers(x0, "x0");
  if (static_cast<int>(start.size()) != n) {
    throw std::invalid_argument(fmt::format("x0 has {} values; model '{}' has {} states ({})", start.size(),
                                            spec.name, n, fmt::join(spec.state_names, ", ")));
  }
  CheckFinite("x0", start);
  Run run{Eigen::Map<const Vec>(start.data(), n),
          CheckedGrid(OptionalNumber(t_end, "t_end").value_or(spec.default_t_end),
                      OptionalNumber(dt, "dt").value_or(spec.default_dt), Spelling::kKeyword),
          SimOptions{}, {}};
  run.inputs = InputsArgument(inputs, spec, run.grid);
  std::vector<double> u0(static_cast<std::size_t>(run.inputs.size()));
  if (!run.inputs.empty()) run.inputs.At(0.0, u0.data());
  const Context at{.t = 0.0, .u = run.inputs.empty() ? nullptr : u0.data()};
  if (!model.InFlowSet(run.x0, at) && !model.InJumpSet(run.x0, at)) {
    throw std::invalid_argument(fmt::format("x0 = {}: outside the flow set C and the jump set D of '{}'",
                                            fmt::join(start, ","), spec.name));
  }
  run.sim.rtol = Number(rtol, "rtol");
  run.sim.atol = Number(atol, "atol");
  CheckSimOptions(run.sim, Spelling::kKeyword);
  return run;
}

py::dict SimulateDict(const py::object& model_arg, const py::object& x0, const py::object& t_end,
                      const py::object& dt, const py::object& sigma, const py::object& seed_arg,
                      const py::object& trial_arg, const py::object& rtol, const py::object& atol,
                      const py::object& inputs) {
  const Model model = ModelArgument(model_arg).model;
  const std::uint64_t seed = Count(seed_arg, "seed"), trial = Count(trial_arg, "trial");
  const int n = model.state_size();
  const Run run = CheckedRun(model, x0, t_end, dt, rtol, atol, inputs);
  const Vec s = CheckedSigma(Numbers(sigma, "sigma"), n, /*allow_zero=*/true, Spelling::kKeyword,
                             MeasuredIndices(model));
  auto stop = std::make_shared<std::atomic<bool>>(false);
  const auto [traj, y] = RunInterruptible<std::pair<Trajectory, Mat>>([model, run, s, seed, trial, stop] {
    Exogenous exo;
    if (!run.inputs.empty()) exo.inputs = &run.inputs;
    SimOptions sim = run.sim;
    sim.stop = stop.get();
    Trajectory traj = hysid::Simulate(model, run.x0, run.grid, sim, exo);
    Mat y = AddMeasurementNoise(traj.x, s, NoiseKey{.seed = seed, .stream = trial});
    return std::pair{std::move(traj), std::move(y)};
  }, stop);
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
  if (!run.inputs.empty()) {  // u at the sample times, as simulate's input columns (identify's u)
    Mat u(run.inputs.size(), Eigen::Index(traj.t.size()));
    for (std::size_t k = 0; k < traj.t.size(); ++k) run.inputs.At(traj.t[k], u.col(Eigen::Index(k)).data());
    out["u"] = Transposed(u);
  }
  out["dt"] = run.grid.dt;
  out["jumps"] = jumps;
  out["status"] = ToString(traj.status.stop);
  out["message"] = traj.status.message;
  return out;
}

// As `hysid sweep`; Ctrl-C stops the runner between units (the journal keeps every finished unit; the
// same call resumes) and raises KeyboardInterrupt at once.
py::dict RunSweepFile(const std::filesystem::path& file, const std::string& out, int threads) {
  const SweepConfig config = ParseSweepFile(file, Builtins());
  SweepOptions options;
  options.out = out.empty() ? config.out : out;
  if (options.out.empty())
    throw std::invalid_argument(fmt::format("out: not given, and {} has no run.out", file.string()));
  if (threads < 0) throw std::invalid_argument(fmt::format("threads = {}: must be >= 0", threads));
  options.threads = threads;
  options.progress = Progress::Mode::kNone;
  auto stop = std::make_shared<std::atomic<bool>>(false);
  SweepOutcome o;
  // Read before the call: an abandoned call may end (and release the lock) between this call's
  // refusal and the message's rewrite.
  const bool abandoned = AbandonedWork().load() > 0;
  try {
    o = RunInterruptible<SweepOutcome>(
        [config, options, stop] { return RunSweep(config, Builtins(), options, stop.get()); }, stop);
  } catch (const std::invalid_argument& e) {
    std::string message = e.what();  // the directory's lock: perhaps held by this process's interrupted call
    if (message.ends_with("is locked); wait for it or use another --out") &&
        (abandoned || AbandonedWork().load() > 0)) {
      message.replace(message.size() - 5, 5,
                      "out (an interrupted run_sweep of this process is finishing "
                      "the units it was running)");
    }
    throw std::invalid_argument(message);
  }
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
  const ModelSpec& spec = m.spec();
  for (const auto& [params, v] : {std::pair{&spec.alpha, &m.alpha()}, std::pair{&spec.beta, &m.beta()},
                                  std::pair{&spec.guard_params, &m.gamma()}}) {
    for (std::size_t i = 0; i < params->size(); ++i) d[py::str((*params)[i].name)] = (*v)[Eigen::Index(i)];
  }
  return d;
}

// The bound as `hysid crlb`: at the model's true α, β and x0 over the model's (or the given) grid.
py::dict CrlbDict(const py::object& model_arg, const py::object& x0, const py::object& t_end,
                  const py::object& dt, const py::object& sigma, const py::object& x0_known_arg,
                  const py::object& rtol, const py::object& atol, const py::object& inputs,
                  const py::object& param_bound, const py::object& mode_arg, const py::object& times) {
  Model model = ModelArgument(model_arg).model;
  ApplyBounds(BoundTexts(param_bound), Spelling::kKeyword, &model);
  const std::string mode_name = mode_arg.is_none() ? std::string() : py::cast<std::string>(py::str(mode_arg));
  const int mode = ModeIndex(mode_name, model, Spelling::kKeyword);
  const int n = model.state_size();
  const Run run = CheckedRun(model, x0, t_end, dt, rtol, atol, inputs);
  const std::vector<int> measured = MeasuredIndices(model);
  const bool all = static_cast<int>(measured.size()) == n;
  const Vec s =
      CheckedNoiseSigma(Numbers(sigma, "sigma"), static_cast<int>(measured.size()), Spelling::kKeyword);
  CheckBoundGrid(run.grid, Spelling::kKeyword);
  const std::vector<std::uint8_t> present =
      times.is_none() ? std::vector<std::uint8_t>{}
                      : SamplesAtTimes(Numbers(times, "times"), run.grid, "times",
                                       [](std::size_t i) { return fmt::format("times[{}]", i); });
  const std::vector<int> known = KnownX0(X0KnownText(x0_known_arg), model, Spelling::kKeyword);
  auto stop = std::make_shared<std::atomic<bool>>(false);
  const Crlb c = RunInterruptible<Crlb>(
      [model, run, s, known, measured, all, n, mode, present, stop] {
        SensitivityOptions options;
        options.sim = run.sim;
        options.sim.stop = stop.get();
        // As `hysid crlb`: every component known, ξ0 is not in θ; some: in θ, held (sd 0).
        const Unknowns unknowns = Unknowns::Of(model, static_cast<int>(known.size()) != n);
        HybridParameters at = HybridParameters::Of(model, run.x0);
        at.initial_mode = mode;
        return HoldKnownX0(
            ComputeCrlb(model, at, run.grid, s, unknowns, options, all ? std::vector<int>{} : measured,
                        run.inputs.empty() ? nullptr : &run.inputs, present),
            unknowns, known, n);
      },
      stop);
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
  out["mean_e_gamma"] = c.mean_e_gamma;
  out["jumps"] = c.jumps;
  out["samples"] = c.samples;
  return out;
}

// Model.jumps: each jump map with its guard, modes and slice of β by name.
py::list JumpMaps(const PyModel& x) {
  const ModelSpec& spec = x.model.spec();
  auto mode = [&](int q) { return q < 0 ? py::object(py::none()) : py::object(py::str(spec.modes[std::size_t(q)])); };
  py::list out;
  for (const JumpMap& map : spec.jumps) {
    py::list beta, rows;
    for (int i = map.beta_first; i < map.beta_first + map.beta_count; ++i) beta.append(spec.beta[std::size_t(i)].name);
    for (const int i : map.rows) rows.append(spec.state_names[std::size_t(i)]);
    out.append(py::dict(py::arg("name") = map.name, py::arg("guard") = spec.guards[std::size_t(map.guard)].name,
                        py::arg("from") = mode(map.from), py::arg("to") = mode(map.to), py::arg("beta") = beta,
                        py::arg("rows") = rows, py::arg("identity") = map.identity));
  }
  return out;
}

// Model.set: a new model with one unknown parameter's true value changed (the model is not changed).
PyModel WithParameter(const PyModel& m, const std::string& name, const py::object& value) {
  PyModel out = m;
  out.model.SetParameter(name, Number(value, "value"));
  return out;
}

void BindModel(py::module_& m) {
  py::class_<PyModel>(
      m, "Model",
      "A hybrid model: a built-in name (hysid.models()) or a model file (TOML). Immutable: set() "
      "returns a new model. Picklable (a model file travels as its text) and comparable "
      "(==: the same source and parameter values)")
      .def(py::init([](const py::object& name_or_file) { return ModelArgument(name_or_file); }),
           py::arg("name_or_file"))
      .def_static(
          "from_file", [](const std::filesystem::path& p) { return ModelFromFile(p.string()); },
          py::arg("path"))
      .def_property_readonly("name", [](const PyModel& x) { return x.model.name(); })
      .def_property_readonly("description", [](const PyModel& x) { return x.model.spec().description; })
      .def_property_readonly("state_names", [](const PyModel& x) { return x.model.spec().state_names; })
      .def_property_readonly(
          "measured",
          [](const PyModel& x) {
            std::vector<std::string> names;
            for (const int i : MeasuredIndices(x.model)) names.push_back(x.model.spec().state_names[std::size_t(i)]);
            return names;
          },
          "the states the data hold (identify's y has these columns, in this order)")
      .def_property_readonly(
          "modes", [](const PyModel& x) { return x.model.spec().modes; },
          "the discrete modes by name ([]: one unnamed mode, the paper's class)")
      .def_property_readonly("jumps", &JumpMaps,
                             "the jump maps: name, guard, from and to (mode names; None: any mode, the mode it "
                             "left), beta (the names of its slice of beta), rows, identity ([]: one map that "
                             "every guard triggers)")
      .def_property_readonly(
          "inputs", [](const PyModel& x) { return x.model.spec().inputs; },
          "the measured inputs by name (identify's u, simulate's and crlb's inputs)")
      .def_property_readonly(
          "parameters", [](const PyModel& x) { return Parameters(x.model); },
          "every parameter of alpha, beta and the guard parameters gamma by name")
      .def_property_readonly(
          "unknowns",
          [](const PyModel& x) {
            py::dict d;
            for (const auto& [key, params] :
                 {std::pair{"alpha", &x.model.spec().alpha}, std::pair{"beta", &x.model.spec().beta},
                  std::pair{"gamma", &x.model.spec().guard_params}}) {
              py::list names;
              for (const Parameter& p : *params) {
                if (!p.known) names.append(p.name);
              }
              d[key] = names;
            }
            return d;
          },
          "the unknown parameters by name: {'alpha': [...], 'beta': [...], 'gamma': [...]} (gamma: the guard "
          "parameters)")
      .def_property_readonly("equations", [](const PyModel& x) { return x.model.spec().equations; })
      .def_property_readonly("default_x0", [](const PyModel& x) { return x.model.spec().default_x0; })
      .def_property_readonly("default_t_end", [](const PyModel& x) { return x.model.spec().default_t_end; })
      .def_property_readonly("default_dt", [](const PyModel& x) { return x.model.spec().default_dt; })
      .def("set", &WithParameter, py::arg("name"), py::arg("value"),
           "a new model with the unknown parameter NAME's true value set to VALUE; this model is unchanged")
      .def("__eq__", [](const PyModel& a, const PyModel& b) { return SameModel(a, b); })
      .def(py::pickle(&ModelState, &ModelFromState))
      .def("__repr__", [](const PyModel& x) {
        return fmt::format("hysid.Model('{}')", x.builtin.empty() ? x.file : x.builtin);
      });
}

}  // namespace
}  // namespace hysid::python

PYBIND11_MODULE(hysid, m) {
  using namespace hysid::python;
  m.doc() = "Identification of hybrid dynamical systems from sampled states (the hysid C++ library)";
  m.attr("__version__") = HYSID_VERSION;
  py::register_exception<std::invalid_argument>(m, "InputError", PyExc_ValueError);
  BindModel(m);
  m.def(
      "models", [] { return Builtins().names(); }, "the built-in model names");
  m.def(
      "simulate", &SimulateDict, py::arg("model"), py::arg("x0") = py::none(), py::arg("t_end") = py::none(),
      py::arg("dt") = py::none(), py::arg("sigma") = 0.0, py::arg("seed") = 1, py::arg("trial") = 0,
      py::arg("rtol") = 1e-12, py::arg("atol") = 1e-12, py::arg("inputs") = py::none(),
      "One trajectory: dict with t, j, x and y (samples × states), u (samples × inputs, a model with inputs), "
      "dt, jumps, status, message. inputs: a model with inputs: None (the model file's default expressions) "
      "or {'t': times, name: values} (t left out: the sample times), linear between samples. Ctrl-C raises "
      "KeyboardInterrupt");
  BindIdentify(m);
  BindCompare(m);
  m.def("crlb", &CrlbDict, py::arg("model"), py::arg("x0") = py::none(), py::arg("t_end") = py::none(),
        py::arg("dt") = py::none(), py::arg("sigma") = 1.0, py::arg("x0_known") = false,
        py::arg("rtol") = hysid::SimOptions{}.rtol, py::arg("atol") = hysid::SimOptions{}.atol,
        py::arg("inputs") = py::none(), py::arg("param_bound") = py::none(), py::arg("mode") = py::none(),
        py::arg("times") = py::none(),
        "The Cramér–Rao lower bound as `hysid crlb`: dict with status, message, names, sd (by name), "
        "covariance, fisher, mean_e_alpha, mean_e_beta, mean_e_gamma, jumps, samples. sigma: per measured "
        "state; x0_known: True/'all' or state names (held: sd 0); inputs as simulate's; param_bound "
        "{name: (lo, hi)}; mode: a hybrid automaton's initial mode by name (None: the model's default); "
        "times: the bound on these sample times only (grid times k*dt, as `--times`; None: every sample)");
  m.def("run_sweep", &RunSweepFile, py::arg("file"), py::arg("out") = "", py::arg("threads") = 0,
        "Runs a sweep file as `hysid sweep` (resumes from the run directory's journal); returns the counts. "
        "Ctrl-C stops it between units (the journal keeps the finished ones) and raises KeyboardInterrupt");
  RegisterExitCheck();
}
