// hysid identify's text report of a hybrid automaton's events (the JSON: experiments/request/events_json.hpp).
#pragma once

#include "core/identify/identifier.hpp"
#include "core/io/sample_data.hpp"
#include "core/model/model.hpp"
#include "sim/events/fitted_events.hpp"

namespace hysid::cli {

// The text report (nothing for a model that is not an automaton).
void PrintEvents(const Model& model, const SampleData& data, const IdentifyResult& result);
// After --refine ml: each event's time from the fitted model beside the detected one, with its
// standard error. Nothing for a model that is not an automaton.
void PrintFittedEvents(const Model& model, const IdentifyResult& result, const FittedEvents& fitted);

}  // namespace hysid::cli
