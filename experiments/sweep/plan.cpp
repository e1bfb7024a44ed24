#include "experiments/sweep/plan.hpp"

#include <bit>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <tuple>

#include <fmt/format.h>

namespace hysid {

bool DetectorUsesR(const std::string& detector) { return detector == "paper"; }
bool DetectorUsesFalseAlarm(const std::string& detector) { return detector == "residual"; }

std::vector<SweepCell> EnumerateCells(const SweepConfig& c) {
  std::vector<SweepCell> cells;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int m = 0; m < static_cast<int>(c.models.size()); ++m) {
    for (double dt : c.grid.dt) {
      for (double sigma : c.grid.sigma) {
        // A detector appears once for each value of the axes it uses, at the first of the others.
        for (std::size_t ri = 0; ri < c.grid.r.size(); ++ri) {
          for (std::size_t pi = 0; pi < c.grid.false_alarm.size(); ++pi) {
            for (const std::string& est : c.grid.estimator) {
              for (const std::string& det : c.grid.detector) {
                const bool uses_r = DetectorUsesR(det), uses_p = DetectorUsesFalseAlarm(det);
                if ((!uses_r && ri > 0) || (!uses_p && pi > 0)) continue;
                cells.push_back({static_cast<long>(cells.size()), m, dt, sigma, uses_r ? c.grid.r[ri] : nan,
                                 uses_p ? c.grid.false_alarm[pi] : nan, est, det});
              }
            }
          }
        }
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
  return NoiseKey{config.seed, static_cast<std::uint64_t>(trial),
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
