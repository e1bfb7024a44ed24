// hysid.compare: candidate model files fitted on the same data and ranked, as `hysid compare`
// (experiments/request/compare_fit.hpp); the data as files, or as arrays in the forms hysid.identify takes;
// the result is the dict of `hysid compare --json`.
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

ComparisonSettings SettingsOf(double holdout, const std::string& holdout_by, double chain_head) {
  const ComparisonSettings settings{.holdout = holdout,
                                    .holdout_by = HoldoutByFromString(holdout_by, "holdout_by"),
                                    .chain_head = chain_head};
  if (std::string error; !settings.IsValid(&error)) {
    if (!(holdout >= 0.0 && holdout <= 0.9))
      throw std::invalid_argument(fmt::format("holdout = {}: must be in [0, 0.9]", holdout));
    throw std::invalid_argument(fmt::format("chain_head = {}: must be in (0, 0.5]", chain_head));
  }
  return settings;
}

// holdout_by='chain' on data of one chain: refused before any fit.
void CheckChains(const ComparisonSettings& settings, const SampleData& data) {
  if (settings.holdout > 0.0 && settings.holdout_by == HoldoutBy::kChain && data.chains() < 2)
    throw std::invalid_argument("holdout_by='chain': " + OneChainReason(data));
}

// The arrays' runs named as SampleDataFromArrays names them, for the report's `data`.
std::vector<std::string> RunNames(const SampleData& data) {
  return data.run_names.empty() ? std::vector<std::string>{data.path} : data.run_names;
}

py::object Compare(const py::object& models, const py::object& data, const py::object& y, const py::object& t,
                   const py::object& dt, const py::object& u, double holdout, const std::string& holdout_by,
                   double chain_head) {
  const std::vector<std::string> files = Paths(models, "models");
  const ComparisonSettings settings = SettingsOf(holdout, holdout_by, chain_head);
  if (data.is_none() == y.is_none()) throw std::invalid_argument("data, y: give the data files (data=) or the samples (y=), one of them");
  if (y.is_none() && !(t.is_none() && dt.is_none() && u.is_none()))
    throw std::invalid_argument("t, dt, u: go with y= (the samples as arrays); data= names files, which carry their own");
  std::string text;
  if (!data.is_none()) {
    const std::vector<std::string> paths = Paths(data, "data");
    text = RunInterruptible<std::string>([files, paths, settings] {
      const auto check = [&](const SampleData& d) { CheckChains(settings, d); };
      return ComparisonJson(paths, settings, CompareModels(files, paths, settings, check)).dump();
    });
  } else {  // the arrays made into each candidate's data here, with the GIL; the fits on their own thread
    const auto loaded = std::make_shared<const std::vector<Model>>(LoadCandidates(files));
    const auto samples = std::make_shared<const std::vector<SampleData>>(CandidateData(
        files, [&](const Model& model) { return SamplesFromArrays(model, y, t, dt, u); }, *loaded));
    CheckChains(settings, samples->front());
    text = RunInterruptible<std::string>([files, loaded, samples, settings] {
      return ComparisonJson(RunNames(samples->front()), settings, CompareLoaded(files, *loaded, *samples, settings))
          .dump();
    });
  }
  return py::module_::import("json").attr("loads")(text);
}

}  // namespace

void BindCompare(py::module_& m) {
  m.def("compare", &Compare, py::arg("models"), py::kw_only(), py::arg("data") = py::none(),
        py::arg("y") = py::none(), py::arg("t") = py::none(), py::arg("dt") = py::none(), py::arg("u") = py::none(),
        py::arg("holdout") = 0.25, py::arg("holdout_by") = "tail", py::arg("chain_head") = 0.1,
        "Candidate model files fitted on the same data and ranked by AIC, BIC and held-out forecast, as "
        "`hysid compare`: models, a list of model file paths (at least 2); the data either as files, data= a CSV "
        "path or a list of them (read as identify reads them), or as samples in the forms hysid.identify takes "
        "(y= a (samples, measured states) array or a list of such arrays, one per run; t= their times or dt= "
        "their spacing; u= the measured inputs); holdout, the fraction of each chain's last samples held out "
        "(0: no hold-out); holdout_by, 'tail' (each chain's last holdout fraction) or 'chain' (each chain left "
        "out in turn: fitted on the others and the first chain_head fraction of it, the rest of it forecast; "
        "needs 2 chains or more). Returns the dict of `hysid compare --json`: models (per file: status, ranked, "
        "k, loglik, aic, delta_aic, aic_weight, bic, ..., estimates, holdout) and best ({aic, bic, holdout}: the "
        "file ranked first); data names the files, or the runs of y ('run 1', ...). Bad input raises InputError "
        "(a ValueError) naming the file or keyword. Ctrl-C raises KeyboardInterrupt");
}

}  // namespace hysid::python
