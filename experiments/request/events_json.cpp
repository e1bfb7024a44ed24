#include "experiments/request/events_json.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/model/automaton.hpp"

namespace hysid {

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


EventComparison CompareEvents(const ModelSpec& spec, const SampleData& data, const IdentifyResult& r) {
  const std::vector<int>& truth = *data.map;
  std::vector<TrueEvent> events;
  for (std::size_t k = 1; k < truth.size(); ++k) {
    const bool event = data.j ? (*data.j)[k] != (*data.j)[k - 1] : truth[k] != truth[k - 1];
    if (event && data.chain_start[k] == 0) events.push_back({static_cast<long>(k), data.t[k], truth[k]});
  }
  return CompareEvents(static_cast<int>(JumpMaps(spec).size()), events, r.events);
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

}  // namespace hysid
