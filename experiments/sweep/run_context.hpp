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

// Everything about a model that changes what a trial computes: its equations (φ, ψ, guards with
// their directions and projections, C, D, the distance to D), every α and β entry with its value and
// whether it is known, the states, identified rows, the flow Jacobian flag and the defaults (x0,
// t_end, δt). Not its description. Part of a sweep's identity for a model file.
nlohmann::json ModelDefinitionJson(const Model& model);

}  // namespace hysid
