// A hybrid automaton's events in the identification's report (core/identify/events.hpp): each event
// with its map, the count per map, the mode sequence, the initial mode, and against a ground-truth
// `map` column (with `j`) the confusion of true map × assigned map, against `q` the share of samples
// in the right mode (docs/outputs.md, key `automaton`). The command line prints the same from the
// helpers here (experiments/cli/identify_events.cpp).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "core/identify/identifier.hpp"
#include "core/identify/metrics.hpp"
#include "core/io/sample_data.hpp"
#include "core/model/automaton.hpp"
#include "core/model/model.hpp"
#include "sim/events/fitted_events.hpp"

namespace hysid {

// Names of mode q, map m and guard g ("none" or the number when out of range).
std::string ModeName(const ModelSpec& spec, int q);
std::string MapName(const std::vector<JumpMap>& maps, int m);
std::string GuardName(const ModelSpec& spec, int g);
// Events per map (the last entry: events without a map).
std::vector<long> PerMap(std::size_t maps, const IdentifyResult& r);
// The runs of equal mode: (first sample, mode).
std::vector<std::pair<std::size_t, int>> ModeRuns(const std::vector<int>& mode);
// Share of samples whose mode is the `q` column's.
double ModeAgreement(const std::vector<int>& q, const std::vector<int>& mode);

// The data's true events (where `j` changes, else where `map` does; at a sample's time) matched to the
// assigned events (core/identify/metrics.hpp CompareEvents).
EventComparison CompareEvents(const ModelSpec& spec, const SampleData& data, const IdentifyResult& result);

// The events as JSON (null for a model that is not an automaton).
nlohmann::json EventsJson(const Model& model, const SampleData& data, const IdentifyResult& result);

// After the refinement: each event's time from the fitted model into `automaton` (EventsJson's):
// `time_fitted`, `time_fitted_se` per event and `fitted_reason`.
void AddFittedEventsJson(const FittedEvents& fitted, nlohmann::json* automaton);

}  // namespace hysid
