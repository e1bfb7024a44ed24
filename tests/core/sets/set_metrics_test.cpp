// Set metrics (one-sided Hausdorff distance D̂ → D, share of Ĉ outside C) against closed forms.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/builtin/bouncing_ball.hpp"
#include "core/builtin/impact_msd.hpp"
#include "core/builtin/impact_pendulum.hpp"
#include "core/sets/set_metrics.hpp"
#include "tests/testing/vec.hpp"

namespace hysid {
namespace {

using testing::V;

SampleSet Set(std::initializer_list<std::pair<double, double>> pts) {
  SampleSet s(2);
  for (const auto& [x, y] : pts) s.Add((Vec(2) << x, y).finished());
  return s;
}

// A model without DistanceToJumpSet (the example of docs/extending.md has none either).
struct NoDistance {
  ModelSpec Spec() const {
    return {.name = "no-distance",
            .description = "test only",
            .state_names = {"x", "v"},
            .alpha = {{"a", 1.0, false, ""}},
            .beta = {{"b", 1.0, false, ""}},
            .flow_rows = {1},
            .jump_rows = {1},
            .guards = {{"wall", Crossing::kFalling}},
            .default_x0 = {1.0, 0.0}};
  }
  void Phi(ConstVecRef x, MatRef phi) const { phi << 0.0, -x[0]; }
  void Psi(ConstVecRef x, MatRef psi) const { psi << 0.0, -x[1]; }
  void Guards(ConstVecRef x, VecRef h) const { h[0] = x[0]; }
  bool InFlowSet(ConstVecRef x) const { return x[0] >= 0.0; }
  bool InJumpSet(ConstVecRef x) const { return x[0] == 0.0 && x[1] <= 0.0; }
};

TEST_CASE("jump_hausdorff: a hand-made D^ against D = {xi1 = 0, xi2 <= 0}", "[set-metrics]") {
  const Model model{ImpactMsd{}};
  const SampleSet flow = Set({{1, 0}, {2, 0}, {1, 1}});
  // Vertices at distances 0, 0.3, 0 and √(0.1² + 0.4²) (the one above the origin).
  const SampleSet jump = Set({{0, -1}, {0.3, -2}, {0, -4}, {0.1, 0.4}, {0.05, -1.5}});
  const SetMetrics m = CompareSets(model, flow, jump);
  CHECK(m.jump_hausdorff == Approx(std::sqrt(0.17)).epsilon(1e-15));
  // The maximum over the polygon is at a vertex (dist(·, D) is convex): no point of a fine grid
  // inside D^ is farther.
  double worst = 0.0;
  for (int i = 0; i <= 400; ++i) {
    for (int j = 0; j <= 400; ++j) {
      const Vec x = (Vec(2) << 0.3 * i / 400.0, -4.0 + 4.4 * j / 400.0).finished();
      if (jump.Contains(x)) worst = std::max(worst, model.DistanceToJumpSet(x));
    }
  }
  CHECK(worst <= m.jump_hausdorff);
  CHECK(worst >= 0.97 * m.jump_hausdorff);  // the grid misses the vertex by < 0.0075
}

TEST_CASE("jump_hausdorff of degenerate hulls: a segment on the wall, across the origin, a point",
          "[set-metrics]") {
  const Model model{BouncingBall{}};
  const SampleSet flow = Set({{1, 0}});
  CHECK(CompareSets(model, flow, Set({{0, -5}, {0, -1}, {0, -3}})).jump_hausdorff == 0.0);
  CHECK(CompareSets(model, flow, Set({{0, -1}, {0, 2}})).jump_hausdorff == 2.0);
  CHECK(CompareSets(model, flow, Set({{3, 4}})).jump_hausdorff == 5.0);
  CHECK(CompareSets(model, flow, Set({{-3, -4}})).jump_hausdorff == 3.0);
  CHECK(std::isnan(CompareSets(model, flow, SampleSet(2)).jump_hausdorff));
}

TEST_CASE("flow_outside_share: a square half outside C is 0.5, a triangle 7/16", "[set-metrics]") {
  const Model model{ImpactPendulum{}};  // C = {xi1 >= 0} up to a null set
  const SampleSet jump = Set({{0, -1}});
  CHECK(CompareSets(model, Set({{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}), jump).flow_outside_share ==
        Approx(0.5).margin(2e-3));
  // (−1,−1), (3,−1), (−1,3): area 8; the part with xi1 < 0 has area ∫_{−1}^{0} (3 − x) dx = 3.5.
  CHECK(CompareSets(model, Set({{-1, -1}, {3, -1}, {-1, 3}}), jump).flow_outside_share ==
        Approx(3.5 / 8.0).margin(2e-3));
  CHECK(CompareSets(model, Set({{0, -1}, {2, -1}, {2, 1}, {0, 1}}), jump).flow_outside_share == 0.0);
  CHECK(CompareSets(model, Set({{-2, -1}, {-1, -1}, {-1, 1}}), jump).flow_outside_share == 1.0);
}

TEST_CASE("flow_outside_share of degenerate hulls and of an empty one", "[set-metrics]") {
  const Model model{ImpactMsd{}};
  const SampleSet jump = Set({{0, -1}});
  // The midpoint rule on 2^16 cells puts x1 = 0 on a cell boundary: exactly a quarter.
  CHECK(CompareSets(model, Set({{-1, 0}, {3, 0}}), jump).flow_outside_share == 0.25);
  CHECK(CompareSets(model, Set({{-1, 0}}), jump).flow_outside_share == 1.0);
  CHECK(CompareSets(model, Set({{1, 0}}), jump).flow_outside_share == 0.0);
  CHECK(std::isnan(CompareSets(model, SampleSet(2), jump).flow_outside_share));
}

TEST_CASE("set metrics: a model without DistanceToJumpSet gives NaN for D^, sizes are checked",
          "[set-metrics]") {
  const Model model{NoDistance{}};
  CHECK_FALSE(model.has_jump_set_distance());
  const SetMetrics m = CompareSets(model, Set({{-1, 0}, {1, 0}, {1, 1}, {-1, 1}}), Set({{0, -1}}));
  CHECK(std::isnan(m.jump_hausdorff));
  CHECK(m.flow_outside_share == Approx(0.5).margin(2e-3));  // InFlowSet is always there
  CHECK_THROWS_AS(CompareSets(model, Mat::Zero(1, 2), Mat::Zero(2, 1)), std::invalid_argument);
}

// Three states, C = {w·ξ ≥ b} (a half-space), D = {ξ1 = 0, ξ2 ≤ 0} (a half-plane).
struct HalfSpace3 {
  Vec w = Vec::Ones(3);
  double b = 1.5;
  ModelSpec Spec() const {
    return {.name = "half-space-3",
            .description = "test only",
            .state_names = {"x", "y", "z"},
            .alpha = {{"a", 1.0, false, ""}},
            .beta = {{"b", 1.0, false, ""}},
            .flow_rows = {0},
            .jump_rows = {0},
            .guards = {{"wall", Crossing::kFalling}},
            .default_x0 = {1.0, 0.0, 0.0}};
  }
  void Phi(ConstVecRef x, MatRef phi) const { phi << -x[0], 0.0, 0.0; }
  void Psi(ConstVecRef x, MatRef psi) const { psi << x[0], x[1], x[2]; }
  void Guards(ConstVecRef x, VecRef h) const { h[0] = x[0]; }
  bool InFlowSet(ConstVecRef x) const { return w.dot(x) >= b; }
  bool InJumpSet(ConstVecRef x) const { return x[0] == 0.0 && x[1] <= 0.0; }
  double DistanceToJumpSet(ConstVecRef x) const { return std::hypot(x[0], std::max(x[1], 0.0)); }
};

SampleSet Set3(std::initializer_list<Vec> pts) {
  SampleSet s(3);
  for (const Vec& x : pts) s.Add(x);
  return s;
}

// The unit cube: corners, with an interior point and a face centre among them.
SampleSet UnitCube() {
  return Set3({V(0.5, 0.5, 0.5), V(0, 0, 0), V(1, 0, 0), V(0, 1, 0), V(1, 1, 0), V(1, 0.5, 0.5), V(0, 0, 1),
               V(1, 0, 1), V(0, 1, 1), V(1, 1, 1)});
}

double Share(const HalfSpace3& c, const SampleSet& flow) {
  return CompareSets(Model{c}, flow, Set3({V(0, -1, 0)})).flow_outside_share;
}

TEST_CASE("3-D flow_outside_share: the unit cube cut by planes, against exact volumes", "[set-metrics]") {
  const SampleSet cube = UnitCube();
  REQUIRE(cube.hull_dimension() == 3);
  // The error bound is the volume share of the sub-simplices cut by C's boundary: with about 2^16
  // cells each is ≈ 1/18 of its cone across, so the bound is a few percent; the errors are far
  // below it (3e-5, 1.5e-4 and 9e-4 for the three cuts below); 5e-3 is asserted.
  // x1 + x2 + x3 ≥ 1.5 halves the cube (point symmetry about its centre).
  CHECK(Share({.w = Vec::Ones(3), .b = 1.5}, cube) == Approx(0.5).margin(5e-3));
  // x1 + x2 + x3 < 0.5 is the corner tetrahedron of volume 0.5³/6 = 1/48.
  CHECK(Share({.w = Vec::Ones(3), .b = 0.5}, cube) == Approx(1.0 / 48.0).margin(5e-3));
  // x1 < 0.3: a slab of volume 0.3.
  CHECK(Share({.w = V(1, 0, 0), .b = 0.3}, cube) == Approx(0.3).margin(5e-3));
  // All of the cube inside C, all outside: exact.
  CHECK(Share({.w = V(1, 0, 0), .b = 0.0}, cube) == 0.0);
  CHECK(Share({.w = V(1, 0, 0), .b = 1.5}, cube) == 1.0);
  // The SampleSet overload is the vertex overload.
  const Model model{HalfSpace3{}};
  const SampleSet jump = Set3({V(0, -1, 0)});
  CHECK(CompareSets(model, cube, jump).flow_outside_share ==
        CompareSets(model, cube.vertices(), jump.vertices()).flow_outside_share);
  CHECK_THROWS_AS(CompareSets(model, Mat::Zero(2, 3), jump.vertices()), std::invalid_argument);
}

TEST_CASE("3-D set metrics of degenerate hulls and jump_hausdorff from the vertices", "[set-metrics]") {
  const SampleSet jump = Set3({V(0, -1, 0)});
  // A square in the plane x3 = 2, half of it with x1 < 0: the share of its area (cut along an edge
  // of its triangles' sub-triangles: exact up to rounding).
  const SampleSet square = Set3({V(-1, -1, 2), V(1, -1, 2), V(1, 1, 2), V(-1, 1, 2), V(0, 0, 2)});
  REQUIRE(square.hull_dimension() == 2);
  CHECK(Share({.w = V(1, 0, 0), .b = 0.0}, square) == Approx(0.5).margin(5e-3));
  // A segment on the x1 axis from −1 to 3: the midpoint rule puts x1 = 0 on a cell boundary.
  CHECK(Share({.w = V(1, 0, 0), .b = 0.0}, Set3({V(-1, 0, 0), V(3, 0, 0), V(1, 0, 0)})) == 0.25);
  CHECK(Share({.w = V(1, 0, 0), .b = 0.0}, Set3({V(-1, 0, 0)})) == 1.0);
  CHECK(Share({.w = V(1, 0, 0), .b = 0.0}, Set3({V(1, 5, 5)})) == 0.0);
  CHECK(std::isnan(Share({}, SampleSet(3))));
  // D̂ with vertices at distances 0, 0.3, 0 and √(0.1² + 0.4²) from the half-plane D, and an interior point.
  const Model model{HalfSpace3{}};
  const SampleSet d_hat = Set3({V(0, -1, 0), V(0.3, -2, 1), V(0, -4, -1), V(0.1, 0.4, 2), V(0.1, -1.5, 0.5)});
  CHECK(CompareSets(model, square, d_hat).jump_hausdorff == Approx(std::sqrt(0.17)).epsilon(1e-15));
  CHECK(std::isnan(CompareSets(model, square, SampleSet(3)).jump_hausdorff));
}

}  // namespace
}  // namespace hysid
