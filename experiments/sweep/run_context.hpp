// The context block every result carries: what built it and how (git revision, build type,
// library versions), in the spirit of Google Benchmark's JSON "context".
#pragma once

#include <vector>

#include <nlohmann/json.hpp>

#include "core/model/model.hpp"

namespace hysid {

nlohmann::json BuildContext();

// The model a run simulated, resolved: its name, every α and β entry ({name, value, known}), the
// initial state, the δt values and the horizon t_end, so a result can be traced to its true values.
nlohmann::json ResolvedModelJson(const Model& model, const std::vector<double>& x0,
                                 const std::vector<double>& dt, double t_end);

}  // namespace hysid
