// hysid identify's files besides the text report: the per-row trace (--trace), the hull vertices
// (--hulls) and the recursive run's part of the --json report. Runs and chains are numbered from 1,
// as in the text report; sample indices from 0 (the samples read, rows with a missing value left out).
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "core/detectors/detector.hpp"
#include "core/identify/identifier.hpp"
#include "core/io/sample_data.hpp"
#include "core/model/model.hpp"

namespace hysid::cli {

// Per sample: its chain, numbered from 1 over all runs.
std::vector<long> ChainNumbers(const SampleData& data);

// One row per data row, in file order: run, chain, line, t, missing (1: a row left out for a missing
// state cell, whose other cells are nan), the detector's statistic and threshold, gamma, the estimate
// of every unknown, and j, true_jump when the data carry j.
void WriteTrace(const std::string& path, const ModelSpec& spec, const DetectorDescriptor& detector,
                const SampleData& data, const IdentifyResult& result);

// set, vertex and one column per state (named after the model's states): the vertices of C^ (set 0)
// and D^ (set 1).
void WriteHulls(const std::string& path, const ModelSpec& spec, const IdentifyResult& result);

// What the text report of the recursive run says, as JSON: model, data, settings, noise, recursive
// (estimates, counts, hulls), detections, chains and, when the data carry j, truth (docs/outputs.md).
nlohmann::json RecursiveJson(const Model& model, const SampleData& data, const IdentifierSettings& settings,
                             const std::string& accuracy_source, const IdentifyResult& result);

}  // namespace hysid::cli
