// SampleSet: the incremental convex hull against closed forms and against CGAL's batch hull.
#include <catch2/catch.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <vector>

#include <Eigen/LU>

#include "core/sets/sample_set.hpp"
#include "tests/testing/vec.hpp"

namespace hysid {
namespace {

using testing::V;

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
    INFO("sample " << k << " = (" << pts.col(k).transpose() << ")");
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
  CHECK(s.Contains(V(0.5, 0.5)));
  CHECK(s.Contains(V(1, 1)));     // a vertex
  CHECK(s.Contains(V(0.25, 1)));  // on an edge
  CHECK_FALSE(s.Contains(V(1 + 1e-12, 0.5)));
  CHECK(s.Contains(V(1 + 1e-12, 0.5), 1e-9));
  CHECK_FALSE(s.Contains(V(2, 0.5), 0.99));  // distance 1 to the edge x = 1
  CHECK(s.Contains(V(2, 0.5), 1.0));
  CHECK_FALSE(s.Contains(V(2, 2), 1.414));  // distance √2 to the corner (1, 1)
  CHECK(s.Contains(V(2, 2), 1.4143));
  CHECK_FALSE(s.Contains(V(std::nan(""), 0.5), 10.0));
}

TEST_CASE("triangle: area 6 and the distance to the hypotenuse", "[sets]") {
  SampleSet s(2);
  AddChecked(s, Cols({{0, 3}, {4, 0}, {1, 1}, {0, 0}}));
  CHECK(s.vertices() == Cols({{0, 0}, {4, 0}, {0, 3}}));
  CHECK(s.Volume() == 6.0);
  // (4, 3) is 12/5 from the line 3x + 4y = 12.
  CHECK_FALSE(s.Contains(V(4, 3), 2.39));
  CHECK(s.Contains(V(4, 3), 2.41));
  CHECK(s.version() == 4);  // (1, 1) was a vertex until (0, 0) made it interior
}

TEST_CASE("degenerate hulls: empty, a point, a segment on xi1 = 0, then a polygon", "[sets]") {
  SampleSet s(2);
  CHECK(s.hull_dimension() == -1);
  CHECK(s.vertices().cols() == 0);
  CHECK(s.vertices().rows() == 2);
  CHECK_FALSE(s.Contains(V(0, 0), 1.0));
  CHECK(s.Volume() == 0.0);
  CHECK(s.version() == 0);

  s.Add(V(0, -1));
  CHECK(s.hull_dimension() == 0);
  s.Add(V(0, -1));  // duplicate
  CHECK(s.version() == 1);
  CHECK(s.vertices() == Cols({{0, -1}}));
  CHECK(s.Contains(V(0, -1)));
  CHECK_FALSE(s.Contains(V(0, -2)));
  CHECK(s.Contains(V(0, -2), 1.0));

  // Jump samples of impact-msd on the wall: the hull is a segment of the half-line D.
  AddChecked(s, Cols({{0, -5}, {0, -3}, {0, -2}, {0, -5}}));
  CHECK(s.hull_dimension() == 1);
  CHECK(s.version() == 2);
  CHECK(s.vertices() == Cols({{0, -5}, {0, -1}}));
  CHECK(s.Volume() == 0.0);
  CHECK(s.Contains(V(0, -3)));
  CHECK_FALSE(s.Contains(V(0, 0)));
  CHECK_FALSE(s.Contains(V(1e-300, -3)));
  CHECK(s.Contains(V(0, 0), 1.0));
  CHECK(s.Contains(V(0.5, -3), 0.5));
  CHECK_FALSE(s.Contains(V(0.5, -3), 0.49));
  // Extending the segment at both ends.
  AddChecked(s, Cols({{0, -7}, {0, 2}}));
  CHECK(s.vertices() == Cols({{0, -7}, {0, 2}}));

  // The first point off the line promotes the hull to a triangle.
  s.Add(V(1, -3));
  CHECK(s.hull_dimension() == 2);
  CHECK(s.version() == 5);
  CHECK(s.vertices() == Cols({{0, -7}, {1, -3}, {0, 2}}));
  CHECK(s.Volume() == 4.5);  // base 9 on xi1 = 0, height 1
  CHECK(s.Contains(V(0, 0)));
  CHECK(s.Contains(V(0.5, -3)));
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

TEST_CASE("samples on a ray from the reference point through a vertex, and across angle 0", "[sets]") {
  // The first triangle's centroid (1, 1) is the reference point (exact in floating point).
  SampleSet s(2);
  Mat all(2, 0);
  auto add = [&](double x, double y) {
    const long before = s.version();
    s.Add(V(x, y));
    all.conservativeResize(2, all.cols() + 1);
    all.col(all.cols() - 1) << x, y;
    CHECK(s.version() == before + 1);
    CHECK(s.vertices() == BatchHullVertices(all));
  };
  add(0, 0);
  add(3, 0);
  add(0, 3);
  add(5, -1);  // on the ray (1,1) → (3,0), beyond (3,0): replaces it
  CHECK(s.vertices() == Cols({{0, 0}, {5, -1}, {0, 3}}));
  add(-1, -1);  // on the ray through (0,0): replaces it
  CHECK(s.vertices() == Cols({{-1, -1}, {5, -1}, {0, 3}}));
  add(6, 0.5);  // its angle around (1,1) is above every vertex's: the wedge wraps around 0
  CHECK(s.vertices() == Cols({{-1, -1}, {5, -1}, {6, 0.5}, {0, 3}}));
  add(12, 3);  // makes (6, 0.5) interior: it lies above the new edge (5,−1)–(12,3)
  CHECK(s.vertices() == Cols({{-1, -1}, {5, -1}, {12, 3}, {0, 3}}));
  add(1, 1e6);  // far above: removes (12, 3)'s neighbour (0, 3)
  CHECK(s.vertices() == Cols({{-1, -1}, {5, -1}, {12, 3}, {1, 1e6}}));
}

TEST_CASE("non-finite samples are ignored and counted", "[sets]") {
  SampleSet s(2);
  s.Add(V(0, 0));
  s.Add(V(std::numeric_limits<double>::quiet_NaN(), 1));
  s.Add(V(1, std::numeric_limits<double>::infinity()));
  CHECK(s.size() == 1);
  CHECK(s.non_finite() == 2);
  CHECK(s.version() == 1);
  CHECK(s.hull_dimension() == 0);
  CHECK_THROWS_AS(s.Add(Vec::Zero(3)), std::invalid_argument);
}

TEST_CASE("a set needs at least one component", "[sets]") {
  CHECK_THROWS_WITH(SampleSet(0), Catch::Contains("dimension 0"));
  CHECK_THROWS_AS(SampleSet(-1), std::invalid_argument);
  CHECK_THROWS_AS(BatchHullVertices(Mat::Zero(0, 4)), std::invalid_argument);
  CHECK_THROWS_AS(HullSimplices(Mat::Zero(2, 4)), std::invalid_argument);
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
          case 2: pts.col(k) << grid(rng), grid(rng); break;            // many collinear triples, duplicates
          default: {                                                    // on the circle of radius 5
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

TEST_CASE("a sampled circle: every sample is a vertex, inner samples do not bump the version", "[sets]") {
  SampleSet s(2);
  const int count = 1000;
  for (int k = 0; k < count; ++k) {
    const double a = 2.0 * std::numbers::pi * k / count;
    s.Add(V(std::cos(a), std::sin(a)));
  }
  CHECK(s.vertices().cols() == BatchHullVertices(s.vertices()).cols());
  CHECK(s.vertices().cols() == count);  // strictly convex: no sample is dropped
  const long v = s.version();
  CHECK(v == count);
  for (int k = 0; k < count; ++k) {  // a smaller circle, in the same angular order as a trajectory
    const double a = 2.0 * std::numbers::pi * (k + 0.5) / count;
    s.Add(V(0.9 * std::cos(a), 0.9 * std::sin(a)));
  }
  CHECK(s.version() == v);
  // Area of the inscribed regular 1000-gon: (n/2) sin(2π/n).
  CHECK(s.Volume() == Approx(0.5 * count * std::sin(2.0 * std::numbers::pi / count)).epsilon(1e-12));
}

TEST_CASE("a triangle too thin for a rounded interior reference point still gives exact hulls", "[sets]") {
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
  t.Add(V(2, 2));
  CHECK(t.vertices() == Cols({{0, 0}, {2, 0}, {2, 2}, {0, 2}}));
  CHECK(t.Volume() == 4.0);
}

// ---------------------------------------------------------------------------------------------
// n ≥ 3

namespace nd {

Vec V(std::initializer_list<double> x) {
  Vec v(static_cast<Eigen::Index>(x.size()));
  Eigen::Index i = 0;
  for (double e : x) v[i++] = e;
  return v;
}

Mat Cols(std::initializer_list<Vec> cols) {
  Mat m(cols.begin()->size(), static_cast<Eigen::Index>(cols.size()));
  Eigen::Index i = 0;
  for (const Vec& c : cols) m.col(i++) = c;
  return m;
}

// Columns in lexicographic order (x1, then x2, ...): the order of vertices() for n ≥ 3.
Mat Lex(Mat m) {
  std::vector<Vec> cols;
  for (Eigen::Index j = 0; j < m.cols(); ++j) cols.push_back(m.col(j));
  std::sort(cols.begin(), cols.end(), [](const Vec& a, const Vec& b) {
    return std::lexicographical_compare(a.data(), a.data() + a.size(), b.data(), b.data() + b.size());
  });
  for (Eigen::Index j = 0; j < m.cols(); ++j) m.col(j) = cols[std::size_t(j)];
  return m;
}

// The corners of [0, side]^n, lexicographic.
Mat Corners(int n, double side) {
  Mat m(n, 1L << n);
  for (long k = 0; k < (1L << n); ++k) {
    for (int i = 0; i < n; ++i) m(i, k) = ((k >> (n - 1 - i)) & 1) ? side : 0.0;
  }
  return m;
}

// An exact check that `vertices` are the extreme points of `points`, independent of how either was
// computed: every vertex is outside the hull of all the other points, and every point is inside the
// hull of the vertices (both with the exact membership test at tolerance 0).
void CheckExtremePoints(const Mat& points, const Mat& vertices) {
  const int n = static_cast<int>(points.rows());
  SampleSet of_vertices(n);
  for (Eigen::Index j = 0; j < vertices.cols(); ++j) of_vertices.Add(vertices.col(j));
  for (Eigen::Index k = 0; k < points.cols(); ++k) {
    INFO("point " << points.col(k).transpose());
    REQUIRE(of_vertices.Contains(points.col(k)));
  }
  for (Eigen::Index j = 0; j < vertices.cols(); ++j) {
    SampleSet others(n);
    for (Eigen::Index k = 0; k < points.cols(); ++k) {
      if (points.col(k) != vertices.col(j)) others.Add(points.col(k));
    }
    INFO("vertex " << vertices.col(j).transpose());
    REQUIRE_FALSE(others.Contains(vertices.col(j)));
  }
}

}  // namespace nd

TEST_CASE("3-D cube: edge and face points first, then corners: the 8 corners, volume 8", "[sets][nd]") {
  using nd::V;
  SampleSet s(3);
  CHECK(s.hull_dimension() == -1);
  CHECK(s.vertices().rows() == 3);
  CHECK(s.vertices().cols() == 0);
  CHECK_FALSE(s.Contains(V({0, 0, 0}), 1.0));
  CHECK(s.Volume() == 0.0);
  // Edge midpoints and face centres of [0, 2]^3 first (collinear, then coplanar, then a solid whose
  // vertices later end up on edges and faces), then the corners, an interior point and repeats.
  const Mat pts =
      nd::Cols({V({1, 0, 0}), V({0, 0, 0}), V({2, 0, 0}), V({1, 1, 0}), V({0, 1, 0}), V({1, 1, 2}),
                V({0, 2, 0}), V({2, 2, 0}), V({2, 0, 2}), V({1, 1, 1}), V({0, 0, 2}), V({2, 2, 2}),
                V({0, 2, 2}), V({2, 0, 0}), V({1, 2, 1}), V({2, 1, 1})});
  std::vector<int> dims;
  for (Eigen::Index k = 0; k < pts.cols(); ++k) {
    const bool inside = s.Contains(pts.col(k));
    const long before = s.version();
    s.Add(pts.col(k));
    INFO("sample " << k);
    REQUIRE(s.version() == before + (inside ? 0 : 1));
    dims.push_back(s.hull_dimension());
  }
  CHECK(dims == std::vector<int>{0, 1, 1, 2, 2, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3});
  CHECK(s.size() == 16);
  CHECK(s.vertices() == nd::Corners(3, 2.0));
  CHECK(s.vertices() == BatchHullVertices(pts));
  CHECK(s.Volume() == Approx(8.0).epsilon(1e-12));
  for (Eigen::Index k = 0; k < pts.cols(); ++k) CHECK(s.Contains(pts.col(k)));
  CHECK(s.Contains(V({2, 1, 0.5})));  // on a face
  CHECK_FALSE(s.Contains(V({2 + 1e-12, 1, 1})));
  CHECK(s.Contains(V({2 + 1e-12, 1, 1}), 1e-9));
  // Distances: 0.5 to the face x1 = 2, √2 to the edge x1 = x2 = 2, √3 to the corner (2, 2, 2).
  CHECK_FALSE(s.Contains(V({2.5, 1, 1}), 0.4999));
  CHECK(s.Contains(V({2.5, 1, 1}), 0.5001));
  CHECK_FALSE(s.Contains(V({3, 3, 1}), 1.4142));
  CHECK(s.Contains(V({3, 3, 1}), 1.4143));
  CHECK_FALSE(s.Contains(V({3, 3, 3}), 1.7320));
  CHECK(s.Contains(V({3, 3, 3}), 1.7321));
  CHECK_FALSE(s.Contains(V({std::nan(""), 1, 1}), 10.0));
  // Inner samples leave the hull and its version alone.
  const long v = s.version();
  for (double t = 0.05; t < 2.0; t += 0.1) s.Add(V({t, 2.0 - t, 0.5 * t}));
  CHECK(s.version() == v);
  nd::CheckExtremePoints(pts, s.vertices());
}

TEST_CASE("3-D degenerate hulls: a point, a segment, a plane, then a pyramid", "[sets][nd]") {
  using nd::V;
  SampleSet s(3);
  s.Add(V({1, 2, 3}));
  s.Add(V({1, 2, 3}));
  CHECK(s.hull_dimension() == 0);
  CHECK(s.version() == 1);
  CHECK(s.vertices() == nd::Cols({V({1, 2, 3})}));
  CHECK(s.Contains(V({1, 2, 3})));
  CHECK(s.Contains(V({1, 2, 4}), 1.0));
  CHECK_FALSE(s.Contains(V({1, 2, 4}), 0.99));

  // Collinear samples on t·(1, 2, 3): a segment.
  for (double t : {3.0, 2.0, -1.0, 0.5, 2.5, -1.0}) s.Add(t * V({1, 2, 3}));
  CHECK(s.hull_dimension() == 1);
  CHECK(s.version() == 3);  // (3,6,9) and (−1,−2,−3) extend it; the others are inside
  CHECK(s.vertices() == nd::Cols({V({-1, -2, -3}), V({3, 6, 9})}));
  CHECK(s.Volume() == 0.0);
  CHECK(s.Contains(V({0, 0, 0})));
  CHECK_FALSE(s.Contains(V({4, 8, 12})));
  CHECK_FALSE(s.Contains(V({1e-300, 0, 0})));
  // (1, −0.5, 0) is orthogonal to (1, 2, 3): at distance |(1, −0.5, 0)| from the segment's middle.
  const double dist = std::sqrt(1.25);
  CHECK(s.Contains(V({2, 1.5, 3}), dist + 1e-9));
  CHECK_FALSE(s.Contains(V({2, 1.5, 3}), dist - 1e-9));

  // Coplanar samples on x3 = x1 + x2 over the square [0, 3]² (integer grid): a parallelogram with
  // the lifted corners as vertices; every grid point on its edges is not extreme.
  SampleSet p(3);
  Mat grid(3, 16);
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j)
      grid.col(4 * ((i + 2 * j) % 4) + j) = V({double(i), double(j), double(i + j)});
  }
  for (Eigen::Index k = 0; k < grid.cols(); ++k) p.Add(grid.col(k));
  CHECK(p.hull_dimension() == 2);
  CHECK(p.Volume() == 0.0);
  const Mat corners = nd::Cols({V({0, 0, 0}), V({0, 3, 3}), V({3, 0, 3}), V({3, 3, 6})});
  CHECK(p.vertices() == corners);
  CHECK(BatchHullVertices(grid) == corners);
  CHECK(p.Contains(V({1.5, 1.5, 3})));
  CHECK_FALSE(p.Contains(V({1.5, 1.5, 3.001})));
  // (1, 1, 2) + t·(1, 1, −1)/√3 is at distance t from the plane, inside the parallelogram's shadow.
  const Vec off = V({1, 1, 2}) + 0.25 * V({1, 1, -1}) / std::sqrt(3.0);
  CHECK(p.Contains(off, 0.2501));
  CHECK_FALSE(p.Contains(off, 0.2499));
  // One sample off the plane: a pyramid over the parallelogram (area 9√3) with height √3: volume 9.
  const long v = p.version();
  p.Add(V({2, 2, 1}));
  CHECK(p.version() == v + 1);
  CHECK(p.hull_dimension() == 3);
  CHECK(p.Volume() == Approx(9.0).epsilon(1e-12));
  CHECK(p.vertices() ==
        nd::Lex(nd::Cols({V({0, 0, 0}), V({0, 3, 3}), V({3, 0, 3}), V({3, 3, 6}), V({2, 2, 1})})));
  CHECK(p.Contains(V({1, 1, 2})));
}

TEST_CASE("unit simplices: volume 1/n!, vertices and membership in 3 to 6 dimensions", "[sets][nd]") {
  for (int n = 3; n <= 6; ++n) {
    INFO("n = " << n);
    SampleSet s(n);
    Mat pts = Mat::Zero(n, n + 2);
    for (int i = 0; i < n; ++i) pts(i, i + 1) = 1.0;
    pts.col(n + 1).setConstant(1.0 / (n + 1));  // an interior point last
    for (Eigen::Index k = 0; k < pts.cols(); ++k) s.Add(pts.col(k));
    CHECK(s.hull_dimension() == n);
    CHECK(s.version() == n + 1);
    CHECK(s.Volume() == Approx(1.0 / std::tgamma(n + 1.0)).epsilon(1e-12));
    CHECK(s.vertices() == nd::Lex(pts.leftCols(n + 1)));
    CHECK(BatchHullVertices(pts) == nd::Lex(pts.leftCols(n + 1)));
    Vec on = Vec::Zero(n), beyond = Vec::Zero(n);
    on.head(2) << 0.5, 0.5;  // on the facet Σx = 1 (exactly: a sum of two halves)
    beyond.head(2) << 0.5, std::nextafter(0.5, 1.0);
    CHECK(s.Contains(on));
    CHECK_FALSE(s.Contains(beyond));
    // Distance from (1, ..., 1) to the facet Σx = 1: (n − 1)/√n (its foot (1/n, ...) is inside it).
    const double d = (n - 1) / std::sqrt(double(n));
    CHECK(s.Contains(Vec::Ones(n), d * (1 + 1e-9)));
    CHECK_FALSE(s.Contains(Vec::Ones(n), d * (1 - 1e-9)));
    // Simplices cover the hull: their volumes add up to Volume().
    double sum = 0.0;
    for (const Mat& t : HullSimplices(pts)) {
      REQUIRE(t.cols() == n + 1);
      sum += std::abs((t.rightCols(n).colwise() - t.col(0)).determinant()) / std::tgamma(n + 1.0);
    }
    CHECK(sum == Approx(1.0 / std::tgamma(n + 1.0)).epsilon(1e-12));
  }
}

// Random clouds in 3-D to 5-D, including integer grids (many coplanar and collinear points,
// duplicates) and integer points on a sphere (all extreme), against CGAL's batch hull
// (CGAL::extreme_points_3 in 3-D; above, a CGAL dD triangulation of all points) and against the
// exact extreme-point characterisation. (3-D, 4-D and n ≥ 5 use different orientation kernels.)
TEST_CASE("random 3-D, 4-D and 5-D clouds give the batch extreme points", "[sets][nd]") {
  std::mt19937_64 rng(20250301);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::uniform_int_distribution<int> grid(-2, 2);
  for (int n = 3; n <= 5; ++n) {
    for (int kind = 0; kind < 4; ++kind) {
      for (int rep = 0; rep < (n == 5 ? 2 : 3); ++rep) {
        const Eigen::Index count = 40 + (n == 5 ? 80 : 150) * rep;
        Mat pts(n, count);
        for (Eigen::Index k = 0; k < count; ++k) {
          for (int i = 0; i < n; ++i) {
            switch (kind) {
              case 0: pts(i, k) = uniform(rng); break;
              case 1: pts(i, k) = (i + 1) * normal(rng); break;
              case 2: pts(i, k) = grid(rng); break;
              default: pts(i, k) = 0.0;
            }
          }
          if (kind == 3) {
            // Integer points with |x|² = 25 and random signs: cospherical, all extreme.
            const int table3[][3] = {{0, 0, 5}, {0, 3, 4}, {0, 4, 3}, {3, 0, 4}, {4, 0, 3}, {3, 4, 0}};
            const int table4[][4] = {{0, 0, 0, 5}, {1, 2, 2, 4}, {2, 4, 1, 2}, {0, 3, 4, 0}, {4, 2, 2, 1}};
            const int table5[][5] = {{0, 0, 0, 0, 5}, {1, 2, 2, 0, 4}, {2, 4, 1, 0, 2}, {0, 3, 0, 4, 0},
                                     {4, 2, 0, 2, 1}, {2, 2, 2, 2, 3}, {1, 0, 2, 2, 4}};
            const int row =
                std::abs(grid(rng)) + (uniform(rng) < 0 ? 0 : 1) + (n == 5 ? 3 * (uniform(rng) < 0) : 0);
            for (int i = 0; i < n; ++i) {
              const int e = n == 3 ? table3[row % 6][i] : n == 4 ? table4[row % 5][i] : table5[row % 7][i];
              pts(i, k) = (uniform(rng) < 0 ? -1 : 1) * e;
            }
          }
        }
        INFO("n " << n << ", kind " << kind << ", " << count << " points");
        SampleSet s(n);
        AddChecked(s, pts);
        CHECK(s.hull_dimension() == n);
        const Mat batch = BatchHullVertices(pts);
        CHECK(s.vertices() == batch);
        for (Eigen::Index k = 0; k < count; ++k) REQUIRE(s.Contains(pts.col(k)));
        nd::CheckExtremePoints(pts, s.vertices());
        // The volume does not depend on the insertion order: the hull of the vertices, reversed.
        SampleSet r(n);
        for (Eigen::Index j = batch.cols() - 1; j >= 0; --j) r.Add(batch.col(j));
        CHECK(r.Volume() == Approx(s.Volume()).epsilon(1e-12));
        CHECK(r.vertices() == batch);
      }
    }
  }
}

// A trajectory-like stream: a 3-D spiral whose early samples are all extreme (in convex position,
// each new one sees O(h) boundary facets), then loops inside the hull.
TEST_CASE("a 3-D spiral: extreme points of a trajectory, inner loops leave the version alone", "[sets][nd]") {
  const int count = 4000;
  Mat pts(3, count);
  for (int k = 0; k < count; ++k) {
    const double t = 0.01 * k;
    const double r = 2.0 + std::cos(0.37 * t);  // radius oscillates: later loops are inside
    pts.col(k) << r * std::cos(t), r * std::sin(t), std::sin(0.2 * t);
  }
  SampleSet s(3);
  const auto start = std::chrono::steady_clock::now();
  AddChecked(s, pts);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  INFO("time " << seconds << " s for " << count << " samples (with a Contains before each)");
  CHECK(seconds < 10.0);
  const Mat batch = BatchHullVertices(pts);
  INFO("vertices " << batch.cols());
  CHECK(s.vertices() == batch);
  for (int k = 0; k < count; ++k) REQUIRE(s.Contains(pts.col(k)));
}

TEST_CASE("3-D: non-finite samples are ignored and counted, a moved set keeps its hull", "[sets][nd]") {
  using nd::V;
  SampleSet s(3);
  s.Add(V({0, 0, 0}));
  s.Add(V({std::numeric_limits<double>::quiet_NaN(), 1, 1}));
  s.Add(V({1, 1, std::numeric_limits<double>::infinity()}));
  CHECK(s.size() == 1);
  CHECK(s.non_finite() == 2);
  CHECK(s.version() == 1);
  CHECK(s.hull_dimension() == 0);
  CHECK_THROWS_AS(s.Add(Vec::Zero(2)), std::invalid_argument);
  CHECK_THROWS_AS(s.Contains(Vec::Zero(4)), std::invalid_argument);
  for (const Vec& x : {V({1, 0, 0}), V({0, 1, 0}), V({0, 0, 1})}) s.Add(x);
  SampleSet t = std::move(s);
  t.Add(V({1, 1, 1}));
  CHECK(t.hull_dimension() == 3);
  CHECK(t.Volume() == Approx(1.0 / 6 + 1.0 / 3).epsilon(1e-12));  // the corner plus its opposite tetrahedron
  CHECK(t.vertices() ==
        nd::Lex(nd::Cols({V({0, 0, 0}), V({1, 0, 0}), V({0, 1, 0}), V({0, 0, 1}), V({1, 1, 1})})));
  // The batch hull skips non-finite columns.
  CHECK(BatchHullVertices(nd::Cols({V({0, 0, 0}), V({NAN, 0, 0}), V({1, 0, 0})})) ==
        nd::Cols({V({0, 0, 0}), V({1, 0, 0})}));
}

TEST_CASE(
    "a raised stop flag ends the n >= 3 hull's final vertices and volume - a lowered one changes nothing",
    "[sets][nd][stop]") {
  using nd::V;
  // A 4-D curve in convex position (every sample extreme): thousands of boundary facets, the star.
  const int count = 300;
  Mat curve(4, count);
  for (int k = 0; k < count; ++k) {
    const double t = 0.02 * k;
    curve.col(k) << std::cos(t), std::sin(t), std::cos(2.0 * t), std::sin(2.0 * t);
  }
  SampleSet star(4);
  for (int k = 0; k < count; ++k) star.Add(curve.col(k));
  REQUIRE(star.hull_dimension() == 4);
  // Coplanar samples in 3-D: the early triangulation, forever (no interior point).
  SampleSet flat(3);
  for (const Vec& x : {V({0, 0, 0}), V({2, 0, 0}), V({0, 2, 0}), V({2, 2, 0}), V({1, 1, 0}), V({1, 0, 0})})
    flat.Add(x);
  REQUIRE(flat.hull_dimension() == 2);
  for (const SampleSet* s : {&star, &flat}) {
    INFO("hull dimension " << s->hull_dimension());
    std::atomic<bool> stop{false};
    const std::optional<Mat> lowered = s->vertices(&stop);
    const std::optional<double> lowered_volume = s->Volume(&stop);
    REQUIRE(lowered.has_value());
    REQUIRE(lowered_volume.has_value());
    CHECK(*lowered == s->vertices());
    CHECK(*lowered == BatchHullVertices(s == &star ? curve : flat.vertices()));
    CHECK(*lowered_volume == s->Volume());
    stop = true;
    CHECK_FALSE(s->vertices(&stop).has_value());
    if (s == &star) CHECK_FALSE(s->Volume(&stop).has_value());
    if (s == &flat) CHECK(s->Volume(&stop) == 0.0);  // below full dimension: nothing to sum
  }
  CHECK(star.vertices().cols() == count);
  CHECK(flat.vertices().cols() == 4);  // the square's corners; (1, 1, 0) and (1, 0, 0) are not extreme
  // 1-D and 2-D hulls are O(h) and not polled.
  SampleSet plane(2);
  for (const Vec& x : {V({0, 0}), V({1, 0}), V({0, 1})}) plane.Add(x);
  std::atomic<bool> raised{true};
  CHECK(plane.vertices(&raised) == plane.vertices());
  CHECK(plane.Volume(&raised) == 0.5);
}

}  // namespace
}  // namespace hysid
