#include "experiments/cli/identify_events.hpp"

#include <algorithm>
#include <cstdio>
#include <string>

#include "core/model/automaton.hpp"
#include "experiments/request/events_json.hpp"

namespace hysid::cli {
namespace {

constexpr std::size_t kListed = 20;  // events and mode runs the text report lists

}  // namespace

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

void PrintFittedEvents(const Model& model, const IdentifyResult& r, const FittedEvents& fitted) {
  if (!IsAutomaton(model.spec()) || r.events.empty()) return;
  const std::vector<JumpMap> maps = JumpMaps(model.spec());
  std::printf("event times from the fitted model (its guard crossings; se from the covariance):\n");
  if (fitted.crossings.size() != r.events.size()) {
    std::printf(
        "  the fitted model crosses its guards %zu times, the detector found %zu events: each detected event "
        "beside the crossing nearest it (every crossing in --json)\n",
        fitted.crossings.size(), r.events.size());
  }
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

}  // namespace hysid::cli
