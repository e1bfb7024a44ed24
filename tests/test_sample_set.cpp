// SampleSet: the incremental convex hull against closed forms and against CGAL's batch hull.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <vector>

#include "core/sample_set.hpp"

namespace hysid {
namespace {

Vec P(double x, double y) {
  Vec v(2);
  v << x, y;
  return v;
}

Mat Cols(std::initializer_list<std::pair<double, double>> pts) {
  Mat m(2, static_cast<Eigen::Index>(pts.size()));
  Eigen::Index i = 0;
  for (const auto& [x, y] : pts) m.col(i++) << x, y;
  return m;
}

// Adds every column; checks that the version moves exactly when the sample was outside the hull.
void AddChecked(SampleSet& s, const Mat& pts) {
  for (Eigen::Index k = 0; k < pts.cols(); ++k) {
    const bool inside = s.Contains(pts.col(k));
    const long before = s.version();
    s.Add(pts.col(k));
    INFO("sample " << k << " = (" << pts(0, k) << ", " << pts(1, k) << ")");
    REQUIRE(s.version() == before + (inside ? 0 : 1));
  }
}

TEST_CASE("square: vertices counter-clockwise, area, membership and distance tolerance", "[sets]") {
  SampleSet s(2);
  // Corners in scrambled order, an interior point, an edge midpoint, a repeated corner.
  AddChecked(s, Cols({{1, 1}, {0.5, 0.5}, {0, 0}, {1, 0}, {0.5, 0}, {0, 1}, {1, 1}}));
  CHECK(s.size() == 7);
  CHECK(s.hull_dimension() == 2);
  CHECK(s.vertices() == Cols({{0, 0}, {1, 0}, {1, 1}, {0, 1}}));
  CHECK(s.Volume() == 1.0);
  CHECK(s.Contains(P(0.5, 0.5)));
  CHECK(s.Contains(P(1, 1)));          // a vertex
  CHECK(s.Contains(P(0.25, 1)));       // on an edge
  CHECK_FALSE(s.Contains(P(1 + 1e-12, 0.5)));
  CHECK(s.Contains(P(1 + 1e-12, 0.5), 1e-9));
  CHECK_FALSE(s.Contains(P(2, 0.5), 0.99));  // distance 1 to the edge x = 1
  CHECK(s.Contains(P(2, 0.5), 1.0));
  CHECK_FALSE(s.Contains(P(2, 2), 1.414));   // distance √2 to the corner (1, 1)
  CHECK(s.Contains(P(2, 2), 1.4143));
  CHECK_FALSE(s.Contains(P(std::nan(""), 0.5), 10.0));
}

TEST_CASE("triangle: area 6 and the distance to the hypotenuse", "[sets]") {
  SampleSet s(2);
  AddChecked(s, Cols({{0, 3}, {4, 0}, {1, 1}, {0, 0}}));
  CHECK(s.vertices() == Cols({{0, 0}, {4, 0}, {0, 3}}));
  CHECK(s.Volume() == 6.0);
  // (4, 3) is 12/5 from the line 3x + 4y = 12.
  CHECK_FALSE(s.Contains(P(4, 3), 2.39));
  CHECK(s.Contains(P(4, 3), 2.41));
  CHECK(s.version() == 4);  // (1, 1) was a vertex until (0, 0) made it interior
}

TEST_CASE("degenerate hulls: empty, a point, a segment on xi1 = 0, then a polygon", "[sets]") {
  SampleSet s(2);
  CHECK(s.hull_dimension() == -1);
  CHECK(s.vertices().cols() == 0);
  CHECK(s.vertices().rows() == 2);
  CHECK_FALSE(s.Contains(P(0, 0), 1.0));
  CHECK(s.Volume() == 0.0);
  CHECK(s.version() == 0);

  s.Add(P(0, -1));
  CHECK(s.hull_dimension() == 0);
  s.Add(P(0, -1));  // duplicate
  CHECK(s.version() == 1);
  CHECK(s.vertices() == Cols({{0, -1}}));
  CHECK(s.Contains(P(0, -1)));
  CHECK_FALSE(s.Contains(P(0, -2)));
  CHECK(s.Contains(P(0, -2), 1.0));

  // Jump samples of impact-msd on the wall: the hull is a segment of the half-line D.
  AddChecked(s, Cols({{0, -5}, {0, -3}, {0, -2}, {0, -5}}));
  CHECK(s.hull_dimension() == 1);
  CHECK(s.version() == 2);
  CHECK(s.vertices() == Cols({{0, -5}, {0, -1}}));
  CHECK(s.Volume() == 0.0);
  CHECK(s.Contains(P(0, -3)));
  CHECK_FALSE(s.Contains(P(0, 0)));
  CHECK_FALSE(s.Contains(P(1e-300, -3)));
  CHECK(s.Contains(P(0, 0), 1.0));
  CHECK(s.Contains(P(0.5, -3), 0.5));
  CHECK_FALSE(s.Contains(P(0.5, -3), 0.49));
  // Extending the segment at both ends.
  AddChecked(s, Cols({{0, -7}, {0, 2}}));
  CHECK(s.vertices() == Cols({{0, -7}, {0, 2}}));

  // The first point off the line promotes the hull to a triangle.
  s.Add(P(1, -3));
  CHECK(s.hull_dimension() == 2);
  CHECK(s.version() == 5);
  CHECK(s.vertices() == Cols({{0, -7}, {1, -3}, {0, 2}}));
  CHECK(s.Volume() == 4.5);  // base 9 on xi1 = 0, height 1
  CHECK(s.Contains(P(0, 0)));
  CHECK(s.Contains(P(0.5, -3)));
}

TEST_CASE("a diagonal segment is extended exactly, then promoted on the other side", "[sets]") {
  SampleSet s(2);
  AddChecked(s, Cols({{1, 1}, {3, 3}, {2, 2}, {-2, -2}, {0.1, 0.1}}));
  CHECK(s.hull_dimension() == 1);
  CHECK(s.vertices() == Cols({{-2, -2}, {3, 3}}));
  AddChecked(s, Cols({{0, 1}}));  // left of the line: counter-clockwise order (-2,-2), (3,3), (0,1)
  CHECK(s.vertices() == Cols({{-2, -2}, {3, 3}, {0, 1}}));
  SampleSet t(2);
  AddChecked(t, Cols({{1, 1}, {3, 3}, {-2, -2}, {1, 0}}));  // right of the line
  CHECK(t.vertices() == Cols({{-2, -2}, {1, 0}, {3, 3}}));
}

TEST_CASE("samples on a ray from the reference point through a vertex, and across angle 0",
          "[sets]") {
  // The first triangle's centroid (1, 1) is the reference point (exact in floating point).
  SampleSet s(2);
  Mat all(2, 0);
  auto add = [&](double x, double y) {
    const long before = s.version();
    s.Add(P(x, y));
    all.conservativeResize(2, all.cols() + 1);
    all.col(all.cols() - 1) << x, y;
    CHECK(s.version() == before + 1);
    CHECK(s.vertices() == BatchHullVertices(all));
  };
  add(0, 0);
  add(3, 0);
  add(0, 3);
  add(5, -1);   // on the ray (1,1) → (3,0), beyond (3,0): replaces it
  CHECK(s.vertices() == Cols({{0, 0}, {5, -1}, {0, 3}}));
  add(-1, -1);  // on the ray through (0,0): replaces it
  CHECK(s.vertices() == Cols({{-1, -1}, {5, -1}, {0, 3}}));
  add(6, 0.5);  // its angle around (1,1) is above every vertex's: the wedge wraps around 0
  CHECK(s.vertices() == Cols({{-1, -1}, {5, -1}, {6, 0.5}, {0, 3}}));
  add(12, 3);   // makes (6, 0.5) interior: it lies above the new edge (5,−1)–(12,3)
  CHECK(s.vertices() == Cols({{-1, -1}, {5, -1}, {12, 3}, {0, 3}}));
  add(1, 1e6);  // far above: removes (12, 3)'s neighbour (0, 3)
  CHECK(s.vertices() == Cols({{-1, -1}, {5, -1}, {12, 3}, {1, 1e6}}));
}

TEST_CASE("non-finite samples are ignored and counted", "[sets]") {
  SampleSet s(2);
  s.Add(P(0, 0));
  s.Add(P(std::numeric_limits<double>::quiet_NaN(), 1));
  s.Add(P(1, std::numeric_limits<double>::infinity()));
  CHECK(s.size() == 1);
  CHECK(s.non_finite() == 2);
  CHECK(s.version() == 1);
  CHECK(s.hull_dimension() == 0);
  CHECK_THROWS_AS(s.Add(Vec::Zero(3)), std::invalid_argument);
}

TEST_CASE("only 1-D and 2-D sets are supported", "[sets]") {
  CHECK_THROWS_WITH(SampleSet(3), Catch::Contains("dimension 3"));
  CHECK_THROWS_AS(SampleSet(0), std::invalid_argument);
  CHECK_THROWS_AS(BatchHullVertices(Mat::Zero(3, 4)), std::invalid_argument);
}

TEST_CASE("1-D: the hull is an interval", "[sets]") {
  SampleSet s(1);
  CHECK(s.hull_dimension() == -1);
  for (double x : {2.0, 2.0, -1.0, 0.5, 4.0}) s.Add(Vec::Constant(1, x));
  CHECK(s.hull_dimension() == 1);
  CHECK(s.version() == 3);
  CHECK(s.vertices() == (Mat(1, 2) << -1.0, 4.0).finished());
  CHECK(s.Volume() == 5.0);
  CHECK(s.Contains(Vec::Constant(1, 4.0)));
  CHECK_FALSE(s.Contains(Vec::Constant(1, 4.5)));
  CHECK(s.Contains(Vec::Constant(1, 4.5), 0.5));
  CHECK(BatchHullVertices((Mat(1, 4) << 3, -1, 4, 2).finished()) == (Mat(1, 2) << -1.0, 4.0).finished());
}

// Random clouds, including exactly collinear and cocircular ones, against CGAL::convex_hull_2.
TEST_CASE("random point sets give the batch CGAL hull, vertex for vertex", "[sets]") {
  std::mt19937_64 rng(20240611);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::uniform_int_distribution<int> grid(-5, 5);
  for (int kind = 0; kind < 4; ++kind) {
    for (int rep = 0; rep < 5; ++rep) {
      const Eigen::Index count = 50 + 400 * rep;
      Mat pts(2, count);
      for (Eigen::Index k = 0; k < count; ++k) {
        switch (kind) {
          case 0: pts.col(k) << uniform(rng), uniform(rng); break;
          case 1: pts.col(k) << normal(rng), 3.0 * normal(rng); break;
          case 2: pts.col(k) << grid(rng), grid(rng); break;  // many collinear triples, duplicates
          default: {                                          // on the circle of radius 5
            const int i = grid(rng), sign = uniform(rng) < 0 ? -1 : 1;  // 3-4-5 and axis points
            const double table[][2] = {{5, 0}, {3, 4}, {4, 3}, {0, 5}, {-3, 4}, {-4, 3}};
            const auto& e = table[std::abs(i) % 6];
            pts.col(k) << sign * e[0], sign * e[1];
          }
        }
      }
      SampleSet s(2);
      AddChecked(s, pts);
      INFO("kind " << kind << ", " << count << " points");
      const Mat batch = BatchHullVertices(pts);
      CHECK(s.vertices() == batch);
      for (Eigen::Index k = 0; k < count; ++k) REQUIRE(s.Contains(pts.col(k)));
      // Area against the shoelace formula on the batch hull.
      double twice = 0.0;
      for (Eigen::Index i = 0; i < batch.cols(); ++i) {
        const Eigen::Index j = (i + 1) % batch.cols();
        twice += batch(0, i) * batch(1, j) - batch(0, j) * batch(1, i);
      }
      CHECK(s.Volume() == Approx(0.5 * twice).epsilon(1e-12));
    }
  }
}

TEST_CASE("a sampled circle: every sample is a vertex, inner samples do not bump the version",
          "[sets]") {
  SampleSet s(2);
  const int count = 1000;
  for (int k = 0; k < count; ++k) {
    const double a = 2.0 * std::numbers::pi * k / count;
    s.Add(P(std::cos(a), std::sin(a)));
  }
  CHECK(s.vertices().cols() == BatchHullVertices(s.vertices()).cols());
  CHECK(s.vertices().cols() == count);  // strictly convex: no sample is dropped
  const long v = s.version();
  CHECK(v == count);
  for (int k = 0; k < count; ++k) {  // a smaller circle, in the same angular order as a trajectory
    const double a = 2.0 * std::numbers::pi * (k + 0.5) / count;
    s.Add(P(0.9 * std::cos(a), 0.9 * std::sin(a)));
  }
  CHECK(s.version() == v);
  // Area of the inscribed regular 1000-gon: (n/2) sin(2π/n).
  CHECK(s.Volume() == Approx(0.5 * count * std::sin(2.0 * std::numbers::pi / count)).epsilon(1e-12));
}

TEST_CASE("a triangle too thin for a rounded interior reference point still gives exact hulls",
          "[sets]") {
  // The rounded centroid of (0,0), (3,0), (0,d) with d the smallest subnormal is (1, 0): on an edge.
  const double d = std::numeric_limits<double>::denorm_min();
  SampleSet s(2);
  AddChecked(s, Cols({{0, 0}, {3, 0}, {0, d}}));
  CHECK(s.hull_dimension() == 2);
  CHECK(s.vertices() == Cols({{0, 0}, {3, 0}, {0, d}}));
  AddChecked(s, Cols({{1, 0}, {0, 2 * d}}));  // inside (on an edge), then outside
  CHECK(s.vertices() == Cols({{0, 0}, {3, 0}, {0, 2 * d}}));
  // A fat triangle ends the thin phase; continue with random points against the batch hull.
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 4.0);
  Mat more(2, 300);
  more.col(0) << 1, 1;
  for (Eigen::Index k = 1; k < more.cols(); ++k) more.col(k) << u(rng), u(rng);
  AddChecked(s, more);
  Mat all(2, 305);
  all << Cols({{0, 0}, {3, 0}, {0, d}, {1, 0}, {0, 2 * d}}), more;
  CHECK(s.vertices() == BatchHullVertices(all));
}

TEST_CASE("a moved-from set's hull lives on in the target", "[sets]") {
  SampleSet s(2);
  AddChecked(s, Cols({{0, 0}, {2, 0}, {0, 2}}));
  SampleSet t = std::move(s);
  t.Add(P(2, 2));
  CHECK(t.vertices() == Cols({{0, 0}, {2, 0}, {2, 2}, {0, 2}}));
  CHECK(t.Volume() == 4.0);
}

}  // namespace
}  // namespace hysid
