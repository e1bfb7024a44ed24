#include "experiments/cli/identify_events.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/model/automaton.hpp"

namespace hysid::cli {
namespace {

constexpr std::size_t kListed = 20;  // events and mode runs the text report lists

std::string ModeName(const ModelSpec& spec, int q) {
  return q >= 0 && q < static_cast<int>(spec.modes.size()) ? spec.modes[std::size_t(q)] : fmt::format("{}", q);
}

std::string MapName(const std::vector<JumpMap>& maps, int m) {
  return m >= 0 && m < static_cast<int>(maps.size()) ? maps[std::size_t(m)].name : "none";
}

std::string GuardName(const ModelSpec& spec, int g) {
  return g >= 0 && g < static_cast<int>(spec.guards.size()) ? spec.guards[std::size_t(g)].name : "none";
}

// Events per map (the last entry: events without a map).
std::vector<long> PerMap(std::size_t maps, const IdentifyResult& r) {
  std::vector<long> out(maps + 1, 0);
  for (const AutomatonEvent& e : r.events) ++out[e.map >= 0 ? std::size_t(e.map) : maps];
  return out;
}

// The runs of equal mode: (first sample, mode).
std::vector<std::pair<std::size_t, int>> ModeRuns(const std::vector<int>& mode) {
  std::vector<std::pair<std::size_t, int>> out;
  for (std::size_t k = 0; k < mode.size(); ++k) {
    if (k == 0 || mode[k] != mode[k - 1]) out.emplace_back(k, mode[k]);
  }
  return out;
}

// Share of samples whose mode is the `q` column's.
double ModeAgreement(const std::vector<int>& q, const std::vector<int>& mode) {
  long same = 0;
  for (std::size_t k = 0; k < q.size(); ++k) same += q[k] == mode[k] ? 1 : 0;
  return q.empty() ? 0.0 : static_cast<double>(same) / static_cast<double>(q.size());
}

}  // namespace

EventComparison CompareEvents(const ModelSpec& spec, const SampleData& data, const IdentifyResult& r) {
  const std::vector<int>& truth = *data.map;
  std::vector<TrueEvent> events;
  for (std::size_t k = 1; k < truth.size(); ++k) {
    const bool event = data.j ? (*data.j)[k] != (*data.j)[k - 1] : truth[k] != truth[k - 1];
    if (event && data.chain_start[k] == 0) events.push_back({static_cast<long>(k), data.t[k], truth[k]});
  }
  return hysid::CompareEvents(static_cast<int>(JumpMaps(spec).size()), events, r.events);
}

void PrintEvents(const Model& model, const SampleData& data, const IdentifyResult& r) {
  const ModelSpec& spec = model.spec();
  if (!IsAutomaton(spec)) return;
  const std::vector<JumpMap> maps = JumpMaps(spec);
  const long jumps = std::count_if(r.events.begin(), r.events.end(), [](const AutomatonEvent& e) { return e.jump; });
  std::printf("events: %zu (%ld jumps, %ld switches); initial mode %s (%s", r.events.size(), jumps,
              static_cast<long>(r.events.size()) - jumps, ModeName(spec, r.initial_mode).c_str(),
              r.initial_mode_inferred ? "inferred: flow residual sum of squares"
              : ModeCount(spec) == 1  ? "the only mode"
                                      : "given");
  for (std::size_t q = 0; r.initial_mode_inferred && q < r.initial_mode_rss.size(); ++q) {
    std::printf("%s %s %.6g", q ? "," : "", ModeName(spec, int(q)).c_str(), r.initial_mode_rss[q]);
  }
  std::printf(")\n  per map:");
  const std::vector<long> per_map = PerMap(maps.size(), r);
  for (std::size_t m = 0; m < maps.size(); ++m) std::printf(" %s %ld", maps[m].name.c_str(), per_map[m]);
  if (per_map.back()) std::printf(", without a map %ld", per_map.back());
  std::printf("\n");
  if (!r.events_reason.empty()) std::printf("  assignment not to be trusted: %s\n", r.events_reason.c_str());
  std::printf("  %8s %12s %-6s %-12s %-12s %-16s %s\n", "sample", "t", "kind", "map", "guard", "mode", "|h|/|grad h|");
  for (std::size_t i = 0; i < std::min(kListed, r.events.size()); ++i) {
    const AutomatonEvent& e = r.events[i];
    const std::string modes = ModeName(spec, e.mode_before) + " -> " + ModeName(spec, e.mode_after);
    std::printf("  %8ld %12.6g %-6s %-12s %-12s %-16s %.3g%s\n", e.sample, e.time, e.jump ? "jump" : "switch",
                MapName(maps, e.map).c_str(), GuardName(spec, e.guard).c_str(), modes.c_str(), e.guard_distance,
                e.armed ? "" : " (not armed)");
  }
  if (r.events.size() > kListed) std::printf("  … %zu more in --json\n", r.events.size() - kListed);
  const auto runs = ModeRuns(r.mode);
  std::printf("  modes:");
  for (std::size_t i = 0; i < std::min(kListed, runs.size()); ++i) {
    std::printf(" %s from t = %.6g%s", ModeName(spec, runs[i].second).c_str(), data.t[runs[i].first],
                i + 1 < runs.size() ? "," : "");
  }
  std::printf("%s\n", runs.size() > kListed ? " …" : "");
  if (data.map) {
    const EventComparison c = CompareEvents(spec, data, r);
    std::printf("truth (columns %s): %ld true events, %ld assigned to their map; rows true, columns assigned\n",
                data.j ? "j, map" : "map", c.true_events, c.right);
    std::printf("  %-12s", "");
    for (std::size_t m = 0; m < maps.size(); ++m) std::printf(" %10s", maps[m].name.c_str());
    std::printf(" %10s\n", "missed");
    for (std::size_t t = 0; t <= maps.size(); ++t) {
      std::printf("  %-12s", t < maps.size() ? maps[t].name.c_str() : "spurious");
      for (long n : c.counts[t]) std::printf(" %10ld", n);
      std::printf("\n");
    }
  }
  if (data.q) std::printf("truth (column q): %.6g of the samples in the right mode\n", ModeAgreement(*data.q, r.mode));
}

nlohmann::json EventsJson(const Model& model, const SampleData& data, const IdentifyResult& r) {
  const ModelSpec& spec = model.spec();
  if (!IsAutomaton(spec)) return nullptr;
  const std::vector<JumpMap> maps = JumpMaps(spec);
  nlohmann::json events = nlohmann::json::array();
  for (const AutomatonEvent& e : r.events) {
    events.push_back({{"sample", e.sample},
                      {"t", e.time},
                      {"kind", e.jump ? "jump" : "switch"},
                      {"map", e.map >= 0 ? nlohmann::json(MapName(maps, e.map)) : nlohmann::json()},
                      {"guard", e.guard >= 0 ? nlohmann::json(GuardName(spec, e.guard)) : nlohmann::json()},
                      {"armed", e.armed},
                      {"mode_before", ModeName(spec, e.mode_before)},
                      {"mode_after", ModeName(spec, e.mode_after)},
                      {"guard_distance", std::isfinite(e.guard_distance) ? nlohmann::json(e.guard_distance) : nlohmann::json()},
                      {"statistic", e.statistic}});
  }
  nlohmann::json per_map = nlohmann::json::object();
  const std::vector<long> counts = PerMap(maps.size(), r);
  for (std::size_t m = 0; m < maps.size(); ++m) per_map[maps[m].name] = counts[m];
  nlohmann::json modes = nlohmann::json::array();
  for (const auto& [first, q] : ModeRuns(r.mode)) {
    modes.push_back({{"first_sample", first}, {"t", data.t[first]}, {"mode", ModeName(spec, q)}});
  }
  nlohmann::json rss = nlohmann::json::object();
  for (std::size_t q = 0; q < r.initial_mode_rss.size(); ++q) {
    const double v = r.initial_mode_rss[q];
    rss[ModeName(spec, int(q))] = std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
  }
  nlohmann::json out = {{"events", events},
                        {"per_map", per_map},
                        {"without_map", counts.back()},
                        {"events_reason", r.events_reason},
                        {"initial_mode", ModeName(spec, r.initial_mode)},
                        {"initial_mode_inferred", r.initial_mode_inferred},
                        {"initial_mode_rss", rss},
                        {"modes", modes},
                        {"truth", nullptr}};
  if (data.map || data.q) {
    nlohmann::json truth = {{"confusion", nullptr}, {"mode_agreement", nullptr}};
    if (data.map) {
      const EventComparison c = CompareEvents(spec, data, r);
      std::vector<std::string> names;
      for (const JumpMap& m : maps) names.push_back(m.name);
      truth["confusion"] = {{"true", names},     {"assigned", names},           {"counts", c.counts},
                            {"true_events", c.true_events}, {"assigned_events", c.detected}, {"right", c.right}};
    }
    if (data.q) truth["mode_agreement"] = ModeAgreement(*data.q, r.mode);
    out["truth"] = truth;
  }
  return out;
}

FittedEvents FittedEventsOf(const Model& model, const SampleData& data, const IdentifyResult& r,
                            const RefineResult& refined) {
  if (!IsAutomaton(model.spec())) return {};
  return FitEventTimes(model, data.t, data.y, data.chain_start, data.u, r, refined);
}

void PrintFittedEvents(const Model& model, const IdentifyResult& r, const FittedEvents& fitted) {
  if (!IsAutomaton(model.spec()) || r.events.empty()) return;
  const std::vector<JumpMap> maps = JumpMaps(model.spec());
  std::printf("event times from the fitted model (its guard crossings; se from the covariance, first chain):\n");
  if (!fitted.reason.empty()) std::printf("  not every event has one: %s\n", fitted.reason.c_str());
  if (!fitted.beyond.empty()) std::printf("  %s\n", fitted.beyond.c_str());
  std::printf("  %8s %-12s %14s %14s %12s\n", "sample", "map", "t detected", "t fitted", "se");
  for (std::size_t i = 0; i < std::min(kListed, r.events.size()); ++i) {
    const AutomatonEvent& e = r.events[i];
    std::printf("  %8ld %-12s %14.8g %14.8g %12.3g\n", e.sample, MapName(maps, e.map).c_str(), e.time,
                fitted.time[i], fitted.se[i]);
  }
  if (r.events.size() > kListed) std::printf("  … %zu more in --json\n", r.events.size() - kListed);
}

void AddFittedEventsJson(const FittedEvents& fitted, nlohmann::json* automaton) {
  if (automaton->is_null() || !automaton->contains("events")) return;
  nlohmann::json& events = (*automaton)["events"];
  auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  for (std::size_t i = 0; i < events.size() && i < fitted.time.size(); ++i) {
    events[i]["time_fitted"] = number(fitted.time[i]);
    events[i]["time_fitted_se"] = number(fitted.se[i]);
  }
  (*automaton)["fitted_reason"] = fitted.reason;
  (*automaton)["fitted_beyond"] = fitted.beyond;
}

}  // namespace hysid::cli
