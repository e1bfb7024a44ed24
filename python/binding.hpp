// What the parts of the `hysid` Python module share: the Python model (a Model with what it was made
// from, for pickling), arguments checked with messages that name the Python argument, NumPy
// conversions, and long computations run so that Ctrl-C interrupts them.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "core/io/sample_data.hpp"
#include "core/model/model.hpp"
#include "core/model/registry.hpp"

namespace hysid::python {

namespace py = pybind11;

// The built-in models (never destroyed: a computation left running after Ctrl-C may still use it).
const ModelRegistry& Builtins();

// hysid.Model: a Model and its source, a built-in name or a model file's path and text, so that a
// pickled model is rebuilt on any machine (the file need not exist there).
struct PyModel {
  Model model;
  std::string builtin;     // the registered name, or "" for a model file
  std::string file, text;  // a model file: the path it was read from, its text
};
// A built-in name, or a model file (a path that exists); errors name the argument.
PyModel MakePyModel(const std::string& name_or_file);
PyModel ModelFromFile(const std::string& path);
// The `model` argument: a hysid.Model, a built-in name or a model file's path (str or os.PathLike).
PyModel ModelArgument(const py::handle& value);
// The pickled state: (builtin, file, text, {unknown parameter: value}), and back.
py::tuple ModelState(const PyModel& m);
PyModel ModelFromState(const py::tuple& state);
bool SameModel(const PyModel& a, const PyModel& b);

// ---- arguments: each error is a ValueError naming the argument and the constraint ----

// A real number (int or float, not bool or str): "NAME: expected a number, got str 'x'".
double Number(const py::handle& value, const std::string& name);
std::optional<double> OptionalNumber(const py::handle& value, const std::string& name);
// An integer >= 0 (seed, trial): "NAME = -1: must be an integer >= 0".
std::uint64_t Count(const py::handle& value, const std::string& name);
// A bool: "NAME: expected True or False, got ...".
bool Flag(const py::handle& value, const std::string& name);
// A str: "NAME: expected a name (str), got ...".
std::string Text(const py::handle& value, const std::string& name);
// Real numbers as a float64 C-contiguous array (no complex, strings, objects or bools), any shape.
py::array_t<double> RealArray(const py::handle& value, const std::string& name);
// A ValueError or TypeError (what a bad value raises), not a KeyboardInterrupt raised meanwhile.
bool IsValueError(const py::error_already_set& e);
// A number or a 1-D sequence of numbers (empty when `value` is None).
std::vector<double> Numbers(const py::handle& value, const std::string& name);
// "(2, 3)": the shape of `a`.
std::string ShapeText(const py::array& a);

// A message of SampleDataFromArrays ("run R:K: column C ('y2'): ...", "run R: ...") with the
// array element named as Python indexes it: "y[K-1, C-2]", "t[K-1]" (with the run first,
// "y[R-1][...]", when `runs`: y was a list of runs). The table's columns after t: `ny` of y, `nu`
// of u ("u[K-1, i]"), then truth['j'].
std::string ArrayMessage(const std::string& message, bool runs, int ny = 1 << 30, int nu = 0);

// x0_known as KnownX0's text (experiments/request/checks.hpp): True or 'all' for every component,
// state names as a list or comma-separated; None or False: not given.
std::optional<std::string> X0KnownText(const py::handle& value);
// param_bound {name: (lo, hi)} as ApplyBounds' texts NAME=LO,HI (numbers as the shortest text).
std::vector<std::string> BoundTexts(const py::handle& value);
// ---- NumPy results ----
py::array_t<double> ToArray(const Vec& v);
// A matrix stored column-major as rows × cols, returned with one row per column (cols × rows).
py::array_t<double> Transposed(const Mat& m);

// ---- Ctrl-C ----

// Computations abandoned after Ctrl-C that are still running (see RunInterruptible).
std::atomic<int>& AbandonedWork();
// At interpreter exit: when abandoned computations still run, says so on stderr and ends the
// process with exit code 130 (as the command line after SIGINT) instead of destroying what they use.
void RegisterExitCheck();

// Runs `work` on its own thread while Python's thread, without the GIL, waits in 50 ms slices and
// checks for signals between them. Ctrl-C (any signal whose handler raises) raises `stop` (when
// given: the sweep runner stops between units) and the handler's exception (KeyboardInterrupt) at
// once; the computation is abandoned: it runs to its end on its thread and its result is dropped.
// `work` must own what it uses (capture by value) and must not touch Python objects.
template <class R>
R RunInterruptible(std::function<R()> work, const std::shared_ptr<std::atomic<bool>>& stop = nullptr) {
  struct State {
    std::packaged_task<R()> task;
    std::atomic<int> phase{0};  // 0 running, 1 finished, 2 abandoned
  };
  auto state = std::make_shared<State>();
  state->task = std::packaged_task<R()>(std::move(work));
  std::future<R> result = state->task.get_future();
  std::thread([state] {
    state->task();
    if (state->phase.exchange(1) == 2) AbandonedWork().fetch_sub(1);
  }).detach();
  while (true) {
    {
      py::gil_scoped_release release;
      if (result.wait_for(std::chrono::milliseconds(50)) == std::future_status::ready) return result.get();
    }
    if (PyErr_CheckSignals() != 0) {
      if (stop) stop->store(true);
      AbandonedWork().fetch_add(1);
      if (state->phase.exchange(2) != 0) AbandonedWork().fetch_sub(1);  // it had just finished
      throw py::error_already_set();
    }
  }
}

// Samples y (and inputs u) at times t or spacing dt, in the forms hysid.identify takes them, as the data
// of `model` with identify's checks and messages (python/identify.cpp). Needs the GIL.
SampleData SamplesFromArrays(const Model& model, const py::object& y, const py::object& t, const py::object& dt,
                             const py::object& u);

// hysid.identify (python/identify.cpp).
void BindIdentify(py::module_& m);
// hysid.compare (python/compare.cpp).
void BindCompare(py::module_& m);

}  // namespace hysid::python
