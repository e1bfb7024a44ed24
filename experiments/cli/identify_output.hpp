// hysid identify's files besides the text report and --json: the per-row trace (--trace) and the hull
// vertices (--hulls). Runs and chains are numbered from 1, as in the text report; sample indices from
// 0 (the samples read, rows with a missing value left out).
#pragma once

#include <string>
#include <vector>

#include "core/detectors/detector.hpp"
#include "core/identify/identifier.hpp"
#include "core/io/sample_data.hpp"
#include "core/model/model.hpp"
#include "sim/events/fitted_outputs.hpp"

namespace hysid::cli {

// One row per data row, in file order: run, chain, line, t, missing (1: a row left out for a missing
// state cell, whose other cells are nan), the detector's statistic and threshold, gamma, the estimate
// of every unknown, and j, true_jump when the data carry j.
void WriteTrace(const std::string& path, const ModelSpec& spec, const DetectorDescriptor& detector,
                const SampleData& data, const IdentifyResult& result);

// The trace at `path` (WriteTrace's) rewritten with FitColumns (experiments/request/outcome_json.hpp)
// after its own columns (nan in a row left out).
void AppendFitColumns(const std::string& path, const ModelSpec& spec, const std::vector<int>& measured,
                      const Mat& y, const FittedOutputs& fitted);

// set, vertex and one column per state (named after the model's states): the vertices of C^ (set 0)
// and D^ (set 1).
void WriteHulls(const std::string& path, const ModelSpec& spec, const IdentifyResult& result);

}  // namespace hysid::cli
