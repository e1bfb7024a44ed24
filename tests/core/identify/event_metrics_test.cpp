// CompareEvents: true events of a hybrid automaton matched to the detected ones one to one within one
// sample, nearest first; the confusion of true × assigned map, missed, spurious and the time error.
#include <cmath>

#include <catch2/catch.hpp>

#include "core/identify/metrics.hpp"

namespace hysid {
namespace {

AutomatonEvent Detected(long sample, double time, int map) {
  AutomatonEvent e;
  e.sample = sample;
  e.time = time;
  e.map = map;
  return e;
}

TEST_CASE("CompareEvents counts right, wrong-map, missed and spurious events", "[metrics]") {
  // Two maps. True events at samples 10 (map 0), 20 (map 1), 30 (map 0), 40 (map 1).
  const std::vector<TrueEvent> truth{{10, 0.095, 0}, {20, 0.195, 1}, {30, 0.295, 0}, {40, 0.395, 1}};
  // 10: right, one sample late; 20: assigned to map 0 (wrong); 30: nothing within one sample (a
  // detection at 32 is spurious); 40: two candidates, the nearer (40) is matched, 41 is spurious.
  const std::vector<AutomatonEvent> detected{Detected(11, 0.11, 0), Detected(20, 0.2, 0), Detected(32, 0.32, 0),
                                             Detected(41, 0.41, 1), Detected(40, 0.4, 1)};
  const EventComparison c = CompareEvents(2, truth, detected);
  CHECK(c.true_events == 4);
  CHECK(c.detected == 5);
  CHECK(c.right == 2);
  CHECK(c.wrong_map() == 1);
  CHECK(c.missed == 1);
  CHECK(c.spurious == 2);
  CHECK(c.counts == std::vector<std::vector<long>>{{1, 0, 1}, {1, 1, 0}, {1, 1, 0}});
  CHECK(c.max_time_error == Approx(0.015));  // sample 11 at 0.11 against 0.095
}

TEST_CASE("CompareEvents puts an event without a map in the last column", "[metrics]") {
  const EventComparison c = CompareEvents(2, {{5, 0.05, 1}}, {Detected(5, 0.05, -1)});
  CHECK(c.right == 0);
  CHECK(c.missed == 0);
  CHECK(c.wrong_map() == 1);
  CHECK(c.counts[1][2] == 1);
  CHECK(c.max_time_error == 0.0);
}

TEST_CASE("CompareEvents with nothing true and nothing detected", "[metrics]") {
  const EventComparison c = CompareEvents(1, {}, {});
  CHECK(c.true_events == 0);
  CHECK(c.spurious == 0);
  CHECK(c.counts == std::vector<std::vector<long>>{{0, 0}, {0, 0}});
}

TEST_CASE("LargestNearestTimeError pairs each true event with the nearest fitted one of its map", "[metrics]") {
  const std::vector<TrueEvent> truth = {{10, 0.100, 0}, {20, 0.200, 1}, {30, 0.300, 0}};
  // Map 0 at 0.102 and 0.297, map 1 at 0.2005; a map-1 crossing at 0.1001 is nearer the first true
  // event than 0.102 but applies the other map.
  const std::vector<TrueEvent> fitted = {{0, 0.1001, 1}, {0, 0.102, 0}, {0, 0.2005, 1}, {0, 0.297, 0}};
  CHECK(LargestNearestTimeError(truth, fitted) == Approx(0.003).margin(1e-12));
  // No crossing of map 1: the nearest of any map (0.297 for the event at 0.2: 0.097).
  const std::vector<TrueEvent> only_zero = {{0, 0.102, 0}, {0, 0.297, 0}};
  CHECK(LargestNearestTimeError(truth, only_zero) == Approx(0.097).margin(1e-12));
  CHECK(std::isnan(LargestNearestTimeError(truth, {})));
  CHECK(LargestNearestTimeError({}, fitted) == 0.0);
}

}  // namespace
}  // namespace hysid
