// hysid.compare: candidate model files fitted on the same data files and ranked, as `hysid compare`
// (experiments/request/compare_fit.hpp); the result is the dict of `hysid compare --json`.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "experiments/request/compare_fit.hpp"
#include "python/binding.hpp"

namespace hysid::python {
namespace {

std::vector<std::string> Paths(const py::object& value, const char* name) {
  if (py::isinstance<py::str>(value) || py::hasattr(value, "__fspath__"))
    return {py::str(py::module_::import("os").attr("fspath")(value)).cast<std::string>()};
  std::vector<std::string> out;
  try {
    for (const py::handle item : value) out.push_back(py::str(py::module_::import("os").attr("fspath")(item)));
  } catch (const py::error_already_set&) {
    throw std::invalid_argument(fmt::format("{}: expected a path or a list of paths", name));
  }
  return out;
}

py::object Compare(const py::object& models, const py::object& data, double holdout) {
  const std::vector<std::string> files = Paths(models, "models"), paths = Paths(data, "data");
  const ComparisonSettings settings{.holdout = holdout};
  if (std::string error; !settings.IsValid(&error))
    throw std::invalid_argument(fmt::format("holdout = {}: must be in [0, 0.9]", holdout));
  const std::string text = RunInterruptible<std::string>([files, paths, settings] {
    const std::vector<Candidate> candidates = CompareModels(files, paths, settings);
    return ComparisonJson(paths, settings, candidates).dump();
  });
  return py::module_::import("json").attr("loads")(text);
}

}  // namespace

void BindCompare(py::module_& m) {
  m.def("compare", &Compare, py::arg("models"), py::kw_only(), py::arg("data"), py::arg("holdout") = 0.25,
        "Candidate model files fitted on the same data files and ranked by AIC, BIC and held-out forecast, as "
        "`hysid compare`: models, a list of model file paths (at least 2); data, a CSV path or a list of them "
        "(read as identify reads them); holdout, the fraction of each chain's last samples held out (0: none). "
        "Returns the dict of `hysid compare --json`: models (per file: status, ranked, k, loglik, aic, "
        "delta_aic, aic_weight, bic, ..., estimates, holdout) and best ({aic, bic, holdout}: the file ranked "
        "first). Bad input raises InputError (a ValueError) naming the file or holdout. Ctrl-C raises "
        "KeyboardInterrupt");
}

}  // namespace hysid::python
