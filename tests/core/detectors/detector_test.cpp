// The detector family: each kind's descriptor is the one at its place in the list.
#include <catch2/catch.hpp>

#include "core/builtin/impact_msd.hpp"
#include "core/detectors/detector.hpp"
#include "tests/testing/plugin_list.hpp"

namespace hysid {
namespace {

TEST_CASE("a kind's descriptor is the one at its place in the list: names and classes agree", "[detector]") {
  const Model model{ImpactMsd{}};
  testing::CheckPluginList<DetectorKind>(
      {{DetectorKind::kPaper, "paper"}, {DetectorKind::kResidual, "residual"}}, [&](DetectorKind kind) {
        DetectorSettings s;
        s.kind = kind;
        return MakeDetector(s, model);
      });
}

}  // namespace
}  // namespace hysid
