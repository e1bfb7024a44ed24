// The identification's outcome described once, as JSON: `hysid identify --json` writes it and Python's
// `hysid.identify` returns it as `report` and reads its `refined` part from it (docs/outputs.md). Runs
// and chains are numbered from 1; sample indices from 0 (the samples read, rows with a missing value
// left out). The fitted model's per-sample columns (the trace's, Python's fit_trace) likewise.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/identify/identifier.hpp"
#include "core/io/sample_data.hpp"
#include "core/model/model.hpp"
#include "experiments/request/request.hpp"
#include "sim/events/fitted_outputs.hpp"

namespace hysid {

// The whole report: the recursive part (RecursiveJson) with the refinement's (estimates, standard
// errors, covariance, checks, CRLB at the truth, fitted events, measured and reconstructed states,
// notes). The outcome must have been through RunRefinement.
nlohmann::json OutcomeJson(const IdentifyOutcome& outcome);

// What the text report of the recursive run says, as JSON: model, data, settings, noise, recursive
// (estimates, counts, hulls), detections, chains and, when the data carry j, truth.
nlohmann::json RecursiveJson(const Model& model, const SampleData& data, const IdentifierSettings& settings,
                             const std::string& accuracy_source, const IdentifyResult& result);

// Per sample: its chain, numbered from 1 over all runs.
std::vector<long> ChainNumbers(const SampleData& data);

// The fitted model's columns, each described once: fit_STATE, sd_STATE per state, residual_STATE (y −
// the fit read on the detected segments, FittedOutputs::matched) per measured state, recursive_STATE
// per state, in_fit, and mode_fitted for a model with several modes; cell(k) for sample k. `y`: the
// samples, n × K, or m × K with the measured rows only (in `measured`'s order); they and `fitted` must
// outlive the columns.
struct FitColumn {
  std::string name;
  std::function<double(long)> cell;
};
std::vector<FitColumn> FitColumns(const ModelSpec& spec, const std::vector<int>& measured, const Mat& y,
                                  const FittedOutputs& fitted);

// The fitted model's events and mode sequence (`fitted_events`); `t` the samples' times.
nlohmann::json FittedEventsJson(const ModelSpec& spec, const std::vector<double>& t, const FittedOutputs& fitted);

}  // namespace hysid
