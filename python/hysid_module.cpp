// The `hysid` Python module: models (built-in names or model files), simulate, identify, the
// Cramér–Rao bound and sweeps, calling the same C++ as the command line. NumPy arrays in and out; samples are
// rows (K × n). No Python code runs per sample; the long calls run without the GIL and Ctrl-C interrupts
// them (python/binding.hpp, RunInterruptible). identify is in python/identify.cpp.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "experiments/cli/checks.hpp"
#include "experiments/sweep/config.hpp"
#include "experiments/sweep/runner.hpp"
#include "python/binding.hpp"
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
};

Run CheckedRun(const Model& model, const py::object& x0, const py::object& t_end, const py::object& dt,
               const py::object& rtol, const py::object& atol) {
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
          SimOptions{}};
  if (!model.InFlowSet(run.x0) && !model.InJumpSet(run.x0)) {
    throw std::invalid_argument(fmt::format("x0 = {}: outside the flow set C and the jump set D of '{}'",
                                            fmt::join(start, ","), spec.name));
  }
  run.sim.rtol = Number(rtol, "rtol");
  run.sim.atol = Number(atol, "atol");
  if (std::string e; !run.sim.IsValid(&e)) {  // "SimOptions::rtol = -1. ...": the keyword alone
    if (e.starts_with("SimOptions::")) e.erase(0, std::string_view("SimOptions::").size());
    throw std::invalid_argument(fmt::format("rtol/atol: {}", e));
  }
  return run;
}

py::dict SimulateDict(const py::object& model_arg, const py::object& x0, const py::object& t_end,
                      const py::object& dt, const py::object& sigma, const py::object& seed_arg,
                      const py::object& trial_arg, const py::object& rtol, const py::object& atol) {
  const Model model = ModelArgument(model_arg).model;
  RefuseBeyondModule(model, "simulate", /*partial_ok=*/true);
  const std::uint64_t seed = Count(seed_arg, "seed"), trial = Count(trial_arg, "trial");
  const int n = model.state_size();
  const Run run = CheckedRun(model, x0, t_end, dt, rtol, atol);
  const Vec s = CheckedSigma(Numbers(sigma, "sigma"), n, /*allow_zero=*/true, Spelling::kKeyword);
  const auto [traj, y] = RunInterruptible<std::pair<Trajectory, Mat>>([model, run, s, seed, trial] {
    Trajectory traj = hysid::Simulate(model, run.x0, run.grid, run.sim);
    Mat y = AddMeasurementNoise(traj.x, s, NoiseKey{.seed = seed, .stream = trial});
    return std::pair{std::move(traj), std::move(y)};
  });
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
  try {
    o = RunInterruptible<SweepOutcome>(
        [config, options, stop] { return RunSweep(config, Builtins(), options, stop.get()); }, stop);
  } catch (const std::invalid_argument& e) {
    std::string message = e.what();  // the directory's lock: perhaps held by this process's interrupted call
    if (message.ends_with("is locked); wait for it or use another --out") && AbandonedWork().load() > 0) {
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
                  const py::object& rtol, const py::object& atol) {
  const Model model = ModelArgument(model_arg).model;
  RefuseBeyondModule(model, "crlb", /*partial_ok=*/false);
  const bool x0_known = Flag(x0_known_arg, "x0_known");
  const Run run = CheckedRun(model, x0, t_end, dt, rtol, atol);
  const Vec s =
      CheckedSigma(Numbers(sigma, "sigma"), model.state_size(), /*allow_zero=*/false, Spelling::kKeyword);
  const Crlb c = RunInterruptible<Crlb>([model, run, s, x0_known] {
    SensitivityOptions options;
    options.sim = run.sim;
    return ComputeCrlb(model, run.x0, run.grid, s, Unknowns::Of(model, !x0_known), options);
  });
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
      py::arg("rtol") = 1e-12, py::arg("atol") = 1e-12,
      "One trajectory: dict with t, j, x and y (samples × states), dt, jumps, status, message. Ctrl-C raises "
      "KeyboardInterrupt");
  BindIdentify(m);
  m.def("crlb", &CrlbDict, py::arg("model"), py::arg("x0") = py::none(), py::arg("t_end") = py::none(),
        py::arg("dt") = py::none(), py::arg("sigma") = 1.0, py::arg("x0_known") = false,
        py::arg("rtol") = hysid::SimOptions{}.rtol, py::arg("atol") = hysid::SimOptions{}.atol,
        "The Cramér–Rao lower bound as `hysid crlb`: dict with status, message, names, sd (by name), "
        "covariance, fisher, mean_e_alpha, mean_e_beta, jumps, samples");
  m.def("run_sweep", &RunSweepFile, py::arg("file"), py::arg("out") = "", py::arg("threads") = 0,
        "Runs a sweep file as `hysid sweep` (resumes from the run directory's journal); returns the counts. "
        "Ctrl-C stops it between units (the journal keeps the finished ones) and raises KeyboardInterrupt");
  RegisterExitCheck();
}
