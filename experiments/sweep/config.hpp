// A sweep file (TOML): the models, the grid of (δt, σ, r, estimator, detector), the identifier's
// settings, and the run's trials, master seed and output directory. docs/method.md "Sweeps" shows the shape.
//
// ParseSweepFile checks everything before a trial runs; every error names the file, the line and the
// key, e.g. "sweep.toml:12: grid.dt: -0.001 must be > 0".
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/identify/identifier.hpp"
#include "core/model/registry.hpp"
#include "sim/simulator.hpp"

namespace hysid {

struct SweepModel {
  std::string name;                                      // registry name
  std::vector<std::pair<std::string, double>> params;    // true parameter values set by the file
  std::vector<double> x0;                                // fixed initial state, or
  std::vector<std::array<double, 2>> x0_range;           // [lo, hi] per component, drawn per trial
  double t_end = 20.0;                                   // s
  Model Build(const ModelRegistry& registry) const;      // with params applied
};

struct SweepGrid {
  std::vector<double> dt, sigma, r;
  std::vector<double> false_alarm;  // residual detector's p (the paper detector ignores it)
  std::vector<std::string> estimator, detector;
};

struct SweepConfig {
  std::string source;  // the file it came from
  std::vector<SweepModel> models;
  SweepGrid grid;
  IdentifierSettings identifier;  // base settings; each cell sets estimator, detector, r (and σ)
  bool known_sigma = false;       // give the cell's σ to the identifier (else it is not told)
  SimOptions simulator;
  // [summary] baseline: per-cell keys (sigma, r, false_alarm, estimator, detector) and their values
  // as trials.csv writes them; summary.csv compares every cell with its baseline (tables.hpp).
  std::vector<std::pair<std::string, std::string>> baseline;
  long trials = 10;               // per cell
  std::uint64_t seed = 1;         // master seed
  std::string out;                // run directory

  // Canonical JSON of everything that determines the results (not `source`, not `out`).
  nlohmann::json ToJson() const;
  // FNV-1a of ToJson().dump(): equal configurations hash equal.
  std::string Hash() const;
};

// Throws std::invalid_argument "FILE:LINE: KEY: problem" (or "FILE: ..." when unreadable).
SweepConfig ParseSweepFile(const std::filesystem::path& path, const ModelRegistry& registry);
// The same from text (`name` stands for the file in errors).
SweepConfig ParseSweepText(std::string_view text, const std::string& name,
                           const ModelRegistry& registry);

}  // namespace hysid
