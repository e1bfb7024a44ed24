// hysid identify's report of a hybrid automaton's events (core/identify/events.hpp): each event with
// its map, the count per map, the mode sequence, the initial mode, and against a ground-truth `map`
// column (with `j`) the confusion of true map × assigned map, against `q` the share of samples in the
// right mode (docs/outputs.md, key `automaton`).
#pragma once

#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "core/identify/identifier.hpp"
#include "core/identify/metrics.hpp"
#include "core/io/sample_data.hpp"
#include "core/model/model.hpp"
#include "sim/events/fitted_events.hpp"

namespace hysid::cli {

// The data's true events (where `j` changes, else where `map` does; at a sample's time) matched to the
// assigned events (core/identify/metrics.hpp CompareEvents).
EventComparison CompareEvents(const ModelSpec& spec, const SampleData& data, const IdentifyResult& result);

// The text report (nothing for a model that is not an automaton).
void PrintEvents(const Model& model, const SampleData& data, const IdentifyResult& result);
// The same as JSON (null for a model that is not an automaton).
nlohmann::json EventsJson(const Model& model, const SampleData& data, const IdentifyResult& result);

// After --refine ml: each event's time from the fitted model (its guard crossing, sim/events) beside
// the detected one, with its standard error. Nothing for a model that is not an automaton.
FittedEvents FittedEventsOf(const Model& model, const SampleData& data, const IdentifyResult& result,
                            const RefineResult& refined);
void PrintFittedEvents(const Model& model, const IdentifyResult& result, const FittedEvents& fitted);
// The same into --json's `automaton` (EventsJson's): `time_fitted`, `time_fitted_se` per event and
// `fitted_reason`.
void AddFittedEventsJson(const FittedEvents& fitted, nlohmann::json* automaton);

}  // namespace hysid::cli
