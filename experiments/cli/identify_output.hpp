// hysid identify's files besides the text report: the per-row trace (--trace), the hull vertices
// (--hulls) and the recursive run's part of the --json report. Runs and chains are numbered from 1,
// as in the text report; sample indices from 0 (the samples read, rows with a missing value left out).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "core/detectors/detector.hpp"
#include "core/identify/identifier.hpp"
#include "core/io/sample_data.hpp"
#include "core/model/model.hpp"
#include "sim/events/fitted_outputs.hpp"

namespace hysid::cli {

// Per sample: its chain, numbered from 1 over all runs.
std::vector<long> ChainNumbers(const SampleData& data);

// One row per data row, in file order: run, chain, line, t, missing (1: a row left out for a missing
// state cell, whose other cells are nan), the detector's statistic and threshold, gamma, the estimate
// of every unknown, and j, true_jump when the data carry j.
void WriteTrace(const std::string& path, const ModelSpec& spec, const DetectorDescriptor& detector,
                const SampleData& data, const IdentifyResult& result);

// The fitted model's columns of the trace, each described once: fit_STATE, sd_STATE per state,
// residual_STATE (y − the fit read on the detected segments, FittedOutputs::matched) per measured state, recursive_STATE per state, in_fit, and mode_fitted for a
// model with several modes; cell(k) for sample k. `y`: the samples, n × K, or m × K with the measured
// rows only (in `measured`'s order); they and `fitted` must outlive the columns.
struct FitColumn {
  std::string name;
  std::function<double(long)> cell;
};
std::vector<FitColumn> FitColumns(const ModelSpec& spec, const std::vector<int>& measured, const Mat& y,
                                  const FittedOutputs& fitted);

// The trace at `path` (WriteTrace's) rewritten with FitColumns after its own columns (nan in a row
// left out).
void AppendFitColumns(const std::string& path, const ModelSpec& spec, const std::vector<int>& measured,
                      const Mat& y, const FittedOutputs& fitted);

// The fitted model's events and mode sequence for --json's `fitted_events` (docs/outputs.md);
// `t` the samples' times.
nlohmann::json FittedEventsJson(const ModelSpec& spec, const std::vector<double>& t, const FittedOutputs& fitted);

// set, vertex and one column per state (named after the model's states): the vertices of C^ (set 0)
// and D^ (set 1).
void WriteHulls(const std::string& path, const ModelSpec& spec, const IdentifyResult& result);

// What the text report of the recursive run says, as JSON: model, data, settings, noise, recursive
// (estimates, counts, hulls), detections, chains and, when the data carry j, truth (docs/outputs.md).
nlohmann::json RecursiveJson(const Model& model, const SampleData& data, const IdentifierSettings& settings,
                             const std::string& accuracy_source, const IdentifyResult& result);

}  // namespace hysid::cli
