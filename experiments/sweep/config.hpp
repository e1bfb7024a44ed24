// A sweep file (TOML): the models, the grid of (δt, σ, sweepable options such as r, estimator,
// detector), the identifier's settings, and the run's trials, master seed and output directory.
// The option keys of [identifier] and [grid] come from the option tables of the estimators and
// detectors (docs/architecture.md, "Estimator and detector descriptors"): an estimator option NAME sets
// the α estimator and jump_NAME the β estimator.
// docs/method.md "Sweeps" shows the shape.
//
// ParseSweepFile checks everything before a trial runs; every error names the file, the line and the
// key, e.g. "sweep.toml:12: grid.dt: -0.001 must be > 0".
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/identify/identifier.hpp"
#include "core/model/registry.hpp"
#include "sim/simulator.hpp"

namespace hysid {

struct SweepModel {
  std::string name;                                    // registry name (or the model file's name)
  std::string file;                                    // model file, when given instead of a name
  std::shared_ptr<const Model> from_file;              // the loaded model file (else null)
  // FNV-1a of the model file's bytes: every byte of it is part of the sweep's identity (guard
  // parameters, input_defaults, measured, ... and comments), so a resume after any edit is refused.
  std::string file_digest;
  std::vector<std::pair<std::string, double>> params;  // true parameter values set by the file
  std::vector<double> x0;                              // fixed initial state, or
  std::vector<std::array<double, 2>> x0_range;         // [lo, hi] per component, drawn per trial
  double t_end = 20.0;                                 // s
  Model Build(const ModelRegistry& registry) const;    // with params applied
};

// The values of one sweepable option (EstimatorOptions() or DetectorOptions() with sweepable set): a
// grid key `[grid] NAME`, a column of trials.csv and summary.csv. Estimator options set the α estimator.
struct OptionAxis {
  enum class Family { kEstimator, kDetector };
  Family family = Family::kDetector;
  std::string name;
  std::vector<double> values;  // the [identifier] value when the grid does not give the key
};

struct SweepGrid {
  std::vector<double> dt, sigma;
  std::vector<OptionAxis> options;  // every sweepable option: estimator options, then detector options
  std::vector<EstimatorKind> estimator;
  std::vector<DetectorKind> detector;
  // "none" or "ml" (sim/refine after the recursive identification). Given in the file: trials.csv gets
  // refine, refine_status and the CRLB columns, summary.csv the CRLB and efficiency columns.
  std::vector<std::string> refine{"none"};
  bool refine_axis = false;
};

struct SweepConfig {
  std::string source;  // the file it came from
  std::vector<SweepModel> models;
  SweepGrid grid;
  IdentifierSettings identifier;  // base settings; each cell sets estimator, detector, its axes (and σ)
  bool known_sigma = false;       // give the cell's σ to the identifier (else it is not told)
  // The true jump labels γ(t) = [j(t) ≠ j(t−δt)] instead of a detector (isolates the estimators);
  // the detector column then reads "oracle". The grid may not give a detector or a detector option.
  bool oracle = false;
  SimOptions simulator;
  // [summary] baseline: per-cell keys (sigma, r, false_alarm, estimator, detector, refine) and their values
  // as trials.csv writes them; summary.csv compares every cell with its baseline (tables.hpp).
  std::vector<std::pair<std::string, std::string>> baseline;
  long trials = 10;        // per cell
  std::uint64_t seed = 1;  // master seed
  std::string out;         // run directory

  // Canonical JSON of everything that determines the results (not `source`, not `out`).
  nlohmann::json ToJson() const;
  // FNV-1a of ToJson().dump(): equal configurations hash equal.
  std::string Hash() const;
};

// FNV-1a (64 bits) of `bytes` as 16 hex digits.
std::string Fnv1aDigest(std::string_view bytes);

// What differs between an earlier sweep's ToJson() and `now`'s, for a refusal: the first differing
// key ("model[0].file_digest (the model file FILE changed)", "grid.sigma[1]", ...); "" when equal.
std::string DescribeConfigChange(const nlohmann::json& before, const SweepConfig& now);

// Throws std::invalid_argument "FILE:LINE: KEY: problem" (or "FILE: ..." when unreadable).
SweepConfig ParseSweepFile(const std::filesystem::path& path, const ModelRegistry& registry);
// The same from text (`name` stands for the file in errors).
SweepConfig ParseSweepText(std::string_view text, const std::string& name, const ModelRegistry& registry);

}  // namespace hysid
