#include "experiments/sweep/plan.hpp"

#include <bit>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <tuple>

#include <fmt/format.h>

namespace hysid {

bool Reads(const OptionAxis& axis, EstimatorKind estimator, DetectorKind detector) {
  return axis.family == OptionAxis::Family::kEstimator ? DescriptorOf(estimator).Reads(axis.name)
                                                       : DescriptorOf(detector).Reads(axis.name);
}

double SweepCell::option(const SweepGrid& grid, std::string_view name) const {
  for (std::size_t i = 0; i < grid.options.size(); ++i) {
    if (grid.options[i].name == name) return options[i];
  }
  throw std::invalid_argument(fmt::format("the sweep grid has no option axis '{}'", name));
}

void SweepCell::Apply(const SweepGrid& grid, IdentifierSettings* s) const {
  s->UseEstimator(estimator);
  s->detector.kind = detector;
  for (std::size_t i = 0; i < grid.options.size(); ++i) {
    if (std::isnan(options[i])) continue;
    const OptionAxis& axis = grid.options[i];
    if (axis.family == OptionAxis::Family::kEstimator) {
      FindOption(EstimatorOptions(), axis.name)->set(s->flow_estimator, options[i]);
    } else {
      FindOption(DetectorOptions(), axis.name)->set(s->detector, options[i]);
    }
  }
}

namespace {

// Advances the odometer `index` over the axes (the last fastest); false after the last combination.
bool Next(const std::vector<OptionAxis>& axes, std::vector<std::size_t>* index) {
  for (std::size_t i = axes.size(); i-- > 0;) {
    if (++(*index)[i] < axes[i].values.size()) return true;
    (*index)[i] = 0;
  }
  return false;
}

// The cells of one (model, δt, σ) at one combination of axis values.
void AddCells(const SweepConfig& c, int model, double dt, double sigma, const std::vector<std::size_t>& index,
              std::vector<SweepCell>* cells) {
  const std::vector<OptionAxis>& axes = c.grid.options;
  for (EstimatorKind est : c.grid.estimator) {
    for (DetectorKind det : c.grid.detector) {
      SweepCell cell{static_cast<long>(cells->size()), model, dt, sigma, {}, est, det};
      bool first = true;
      for (std::size_t i = 0; i < axes.size(); ++i) {
        const bool reads = Reads(axes[i], est, det);
        first = first && (reads || index[i] == 0);
        cell.options.push_back(reads ? axes[i].values[index[i]] : std::numeric_limits<double>::quiet_NaN());
      }
      if (!first) continue;
      for (const std::string& refine : c.grid.refine) {  // refine varies fastest
        cell.index = static_cast<long>(cells->size());
        cell.refine = refine;
        cells->push_back(cell);
      }
    }
  }
}

}  // namespace

std::vector<SweepCell> EnumerateCells(const SweepConfig& c) {
  std::vector<SweepCell> cells;
  for (int m = 0; m < static_cast<int>(c.models.size()); ++m) {
    for (double dt : c.grid.dt) {
      for (double sigma : c.grid.sigma) {
        std::vector<std::size_t> index(c.grid.options.size(), 0);
        do {
          AddCells(c, m, dt, sigma, index, &cells);
        } while (Next(c.grid.options, &index));
      }
    }
  }
  return cells;
}

std::string Shard::ToString() const { return fmt::format("{}/{}", k, n); }

Shard ParseShard(const std::string& text) {
  const auto slash = text.find('/');
  Shard s;
  try {
    if (slash == std::string::npos) throw std::invalid_argument("");
    std::size_t used = 0;
    s.k = std::stol(text.substr(0, slash), &used);
    if (used != slash) throw std::invalid_argument("");
    s.n = std::stol(text.substr(slash + 1), &used);
    if (used != text.size() - slash - 1) throw std::invalid_argument("");
  } catch (const std::exception&) {
    throw std::invalid_argument(fmt::format("--shard = '{}': expected K/N, e.g. 1/4", text));
  }
  if (s.n < 1 || s.k < 1 || s.k > s.n) {
    throw std::invalid_argument(fmt::format("--shard = '{}': need 1 ≤ K ≤ N", text));
  }
  return s;
}

std::vector<TrajectoryGroup> GroupUnits(const SweepConfig& config, const std::vector<SweepCell>& cells,
                                        const std::vector<long>& units) {
  // Key: (model, δt index, x0 trial). std::map keeps the order deterministic.
  std::map<std::tuple<int, double, long>, TrajectoryGroup> groups;
  for (long id : units) {
    const UnitId u = UnitOf(id, config.trials);
    const SweepCell& cell = cells[static_cast<std::size_t>(u.cell)];
    const long x0_trial = config.models[static_cast<std::size_t>(cell.model)].x0_range.empty() ? -1 : u.trial;
    TrajectoryGroup& g = groups[{cell.model, cell.dt, x0_trial}];
    g.model = cell.model;
    g.dt = cell.dt;
    g.x0_trial = x0_trial;
    g.units.push_back(id);
  }
  std::vector<TrajectoryGroup> out;
  out.reserve(groups.size());
  for (auto& [key, g] : groups) out.push_back(std::move(g));
  return out;
}

NoiseKey TrialNoiseKey(const SweepConfig& config, int model, double dt, long trial) {
  return NoiseKey{config.seed,
                  static_cast<std::uint64_t>(trial),
                  {static_cast<std::uint64_t>(model), std::bit_cast<std::uint64_t>(dt)}};
}

std::vector<std::vector<long>> UnitsByTrial(const TrajectoryGroup& group, long trials) {
  std::map<long, std::vector<long>> by_trial;
  for (long id : group.units) by_trial[UnitOf(id, trials).trial].push_back(id);
  std::vector<std::vector<long>> out;
  out.reserve(by_trial.size());
  for (auto& [trial, ids] : by_trial) out.push_back(std::move(ids));
  return out;
}

Vec InitialState(const SweepConfig& config, int model, long trial) {
  const SweepModel& m = config.models[static_cast<std::size_t>(model)];
  if (m.x0_range.empty()) return Eigen::Map<const Vec>(m.x0.data(), static_cast<Eigen::Index>(m.x0.size()));
  Vec x0(static_cast<Eigen::Index>(m.x0_range.size()));
  const NoiseKey key{config.seed, static_cast<std::uint64_t>(trial)};
  for (Eigen::Index i = 0; i < x0.size(); ++i) {
    const Uniform4 u = Uniforms(key, RandomPurpose::kInitialState, static_cast<std::uint64_t>(model),
                                static_cast<std::uint64_t>(i / 4));
    const auto& [lo, hi] = m.x0_range[static_cast<std::size_t>(i)];
    x0[i] = lo + (hi - lo) * u.v[i % 4];
  }
  return x0;
}

}  // namespace hysid
