// The n ≥ 3 convex hull behind SampleSet (see core/sets/sample_set.hpp for what it promises and
// core/sets/hull_nd.hpp for the interface). Two representations, both with CGAL's exact predicates:
//
//   early    a CGAL dD triangulation (CGAL::Triangulation, Epick_d) of the samples that were outside
//            the hull when they arrived. It handles every degenerate hull (one point, collinear,
//            coplanar, ... through current_dimension()) exactly. It is used until the hull is
//            n-dimensional and a reference point c strictly inside is known — normally from the
//            (n+1)-th affinely independent sample on, forever when the samples lie in a lower-
//            dimensional flat.
//   star     the boundary of the hull as a set of (n−1)-simplices (facets) with their neighbours,
//            seen from c: the cones (c, F) triangulate the hull. This is the 2-D angular ring of
//            sample_set.cpp in n dimensions. Why not keep the dD triangulation: it never deletes a
//            cell, and for trajectory data it grows quadratically — samples along a smooth curve
//            are in convex position, each new one sees O(h) boundary facets, and the triangulation
//            keeps every cone it ever built (10^7 cells after 5000 samples of a 3-D spiral; 40001
//            such samples exhausted 23 GB). The star holds only the current boundary.
//
// Star operations. locate(q): a remembering stochastic visibility walk over the cones, from the
// previous sample's facet (consecutive samples are close: a few steps), each step one orientation
// test per ridge; it ends in a facet F whose cone holds q, and one more orientation test against F
// decides inside / outside. Insertion of an outside q (beneath-beyond): the facets that q strictly
// sees are connected; they are removed and each horizon ridge is joined to q. Cost O(n · facets
// seen). Coplanar facets are kept (not merged), so a boundary vertex may end up in the relative
// interior of a hull face; Vertices() filters those exactly (below).
//
// Orientation predicates of the star: n = 3 the 3-D kernel's (Epick), n = 4 Epick_d with a static
// dimension, n ≥ 5 Epick_d with a dynamic one (which allocates: 8 times slower than the static one on
// 4-D trajectory data). The early triangulation always uses the dynamic kernel.
#include "core/sets/hull_nd.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <iterator>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <utility>
#include <vector>

#include <CGAL/Epick_d.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation.h>
#include <CGAL/convex_hull_3.h>
#include <Eigen/LU>
#include <Eigen/QR>
#include <boost/container/small_vector.hpp>
#include <boost/iterator/indirect_iterator.hpp>

#include "core/sets/demand.hpp"

namespace hysid::internal {
namespace {

using Epick = CGAL::Exact_predicates_inexact_constructions_kernel;
using KernelD = CGAL::Epick_d<CGAL::Dynamic_dimension_tag>;
using PointD = KernelD::Point_d;
using Triangulation = CGAL::Triangulation<KernelD>;

// Internal invariants (style tier b): always on, abort.
void Demand(bool ok, const char* what) { sets_internal::Demand(ok, "SampleSet (n >= 3)", what); }

bool Outside(Triangulation::Locate_type lt) {
  return lt == Triangulation::OUTSIDE_CONVEX_HULL || lt == Triangulation::OUTSIDE_AFFINE_HULL;
}

// Looks at a stop flag (null: never) at the first of every `every` calls of Raised(): the final
// vertices and volume poll it between boundary facets and between exact vertex tests.
class StopPoll {
 public:
  StopPoll(const std::atomic<bool>* stop, long every) : stop_(stop), every_(every) {}
  bool Raised() {
    return stop_ != nullptr && count_++ % every_ == 0 && stop_->load(std::memory_order_relaxed);
  }

 private:
  const std::atomic<bool>* stop_;
  long every_;
  long count_ = 0;
};

constexpr long kFacetsPerPoll = 4096;  // facets (or cells) between two looks at the stop flag
constexpr long kTestsPerPoll = 16;     // exact vertex tests (a small dD triangulation each) between two

double Factorial(int k) {
  double f = 1.0;
  for (int i = 2; i <= k; ++i) f *= i;
  return f;
}

// The columns `which` of coords (n × V), sorted lexicographically (x1, then x2, ...).
Mat SortedColumns(const Eigen::Ref<const Mat>& coords, std::vector<int> which) {
  const auto n = coords.rows();
  std::sort(which.begin(), which.end(), [&](int a, int b) {
    const double* pa = coords.col(a).data();
    const double* pb = coords.col(b).data();
    return std::lexicographical_compare(pa, pa + n, pb, pb + n);
  });
  Mat m(n, static_cast<Eigen::Index>(which.size()));
  for (std::size_t i = 0; i < which.size(); ++i) m.col(Eigen::Index(i)) = coords.col(which[i]);
  return m;
}

Mat SortedColumns(const std::vector<Vec>& cols, int n) {
  Mat m(n, static_cast<Eigen::Index>(cols.size()));
  for (std::size_t i = 0; i < cols.size(); ++i) m.col(Eigen::Index(i)) = cols[i];
  std::vector<int> all(cols.size());
  std::iota(all.begin(), all.end(), 0);
  return SortedColumns(m, std::move(all));
}

// Squared Euclidean distance from q to conv(columns of v), a simplex of any dimension: the projection
// onto its affine hull if its barycentric coordinates are all ≥ 0, else the nearest of the facets
// opposite a negative coordinate (the nearest point lies on one of them). Floating point.
double SquaredDistanceToSimplex(const Vec& q, const Mat& v) {
  const Eigen::Index k = v.cols();
  if (k == 1) return (q - v.col(0)).squaredNorm();
  const Mat e = v.rightCols(k - 1).colwise() - v.col(0);
  const Vec mu = e.colPivHouseholderQr().solve(q - v.col(0));
  Vec lambda(k);
  lambda[0] = 1.0 - mu.sum();
  lambda.tail(k - 1) = mu;
  if ((lambda.array() >= 0.0).all()) return (q - v.col(0) - e * mu).squaredNorm();
  double best = std::numeric_limits<double>::infinity();
  Mat facet(v.rows(), k - 1);
  for (Eigen::Index i = 0; i < k; ++i) {
    if (lambda[i] >= 0.0) continue;
    for (Eigen::Index j = 0, c = 0; j < k; ++j) {
      if (j != i) facet.col(c++) = v.col(j);
    }
    best = std::min(best, SquaredDistanceToSimplex(q, facet));
  }
  return best;
}

PointD ToPointD(const double* x, int n) { return PointD(x, x + n); }

Vec ToVec(const PointD& p, int n) {
  Vec v(n);
  for (int i = 0; i < n; ++i) v[i] = p[i];
  return v;
}

// Is p in the convex hull of `others`? Exact: a dD triangulation of `others` and one locate.
bool InConvexHull(const PointD& p, const std::vector<PointD>& others, int n) {
  if (others.empty()) return false;
  Triangulation t(n);
  t.insert(others.begin(), others.end());
  Triangulation::Locate_type lt;
  Triangulation::Face face(n);
  Triangulation::Facet facet;
  t.locate(p, lt, face, facet, Triangulation::Full_cell_handle());
  return !Outside(lt);
}

// The extreme points among the vertices of a triangulated hull boundary of affine dimension d ≥ 2
// (facets of d vertices each, ids into `coords`, n × V). flat[f·d + i] says whether the vertex of
// the neighbouring facet across the ridge opposite slot i lies in the affine hull of facet f.
//
// A boundary vertex v is extreme unless it lies in the relative interior of a face G (dim G ≥ 1) of
// the hull. Then, in a hull facet A ⊇ G, at least two boundary facets of A contain v (one simplex
// has a pointed cone at its vertex; A's cone at v holds a line), and the facets of A around v are
// connected through ridges containing v, so two of them are neighbours across such a ridge and
// coplanar: `flat` is set there. So a vertex on no flat ridge is extreme (no more work, the usual
// case), and any other v is tested exactly: v is extreme iff it is outside the hull of its boundary
// neighbours (the facets of A around v cover a neighbourhood of v in A, so v ∈ conv(their vertices
// other than v) when it is not extreme, and the converse holds as they are points of the set).
// Nullopt when *stop is raised (looked at every kTestsPerPoll vertex tests).
std::optional<Mat> ExtremeBoundaryVertices(int n, int d, const std::vector<int>& facets,
                                           const std::vector<char>& flat, const Eigen::Ref<const Mat>& coords,
                                           const std::atomic<bool>* stop) {
  const std::size_t count = facets.size() / static_cast<std::size_t>(d);
  std::vector<char> on_boundary(static_cast<std::size_t>(coords.cols()), 0);
  std::vector<char> suspect(static_cast<std::size_t>(coords.cols()), 0);
  for (std::size_t f = 0; f < count; ++f) {
    for (int i = 0; i < d; ++i) {
      on_boundary[std::size_t(facets[f * d + i])] = 1;
      if (!flat[f * d + i]) continue;
      for (int j = 0; j < d; ++j) {
        if (j != i) suspect[std::size_t(facets[f * d + j])] = 1;
      }
    }
  }
  // Boundary neighbours of each suspect vertex.
  std::map<int, std::vector<int>> neighbours;
  for (std::size_t f = 0; f < count; ++f) {
    for (int i = 0; i < d; ++i) {
      const int v = facets[f * d + i];
      if (!suspect[std::size_t(v)]) continue;
      std::vector<int>& nb = neighbours[v];
      for (int j = 0; j < d; ++j) {
        if (j != i) nb.push_back(facets[f * d + j]);
      }
    }
  }
  std::vector<int> extreme;
  StopPoll poll(stop, kTestsPerPoll);
  for (Eigen::Index v = 0; v < coords.cols(); ++v) {
    if (!on_boundary[std::size_t(v)]) continue;
    if (suspect[std::size_t(v)]) {
      if (poll.Raised()) return std::nullopt;
      std::vector<int>& nb = neighbours[int(v)];
      std::sort(nb.begin(), nb.end());
      nb.erase(std::unique(nb.begin(), nb.end()), nb.end());
      std::vector<PointD> others;
      others.reserve(nb.size());
      for (int u : nb) others.push_back(ToPointD(coords.col(u).data(), n));
      if (InConvexHull(ToPointD(coords.col(v).data(), n), others, n)) continue;
    }
    extreme.push_back(static_cast<int>(v));
  }
  return SortedColumns(coords, std::move(extreme));
}

// The extreme points of a dD triangulation's vertex set; nullopt when *stop is raised (looked at
// every kFacetsPerPoll boundary cells and every kTestsPerPoll vertex tests).
std::optional<Mat> TriangulationExtremePoints(const Triangulation& tri, int n,
                                              const std::atomic<bool>* stop) {
  const int d = tri.current_dimension();
  if (d <= 1) {
    // Empty, one point, or a segment: its two ends are the finite vertices of the infinite cells.
    std::vector<Vec> pts;
    if (d == 0) pts.push_back(ToVec(tri.finite_vertices_begin()->point(), n));
    if (d == 1) {
      std::vector<Triangulation::Full_cell_const_handle> cells;
      tri.incident_full_cells(tri.infinite_vertex(), std::back_inserter(cells));
      for (const auto& c : cells) {
        for (int i = 0; i <= 1; ++i) {
          if (!tri.is_infinite(c->vertex(i))) pts.push_back(ToVec(c->vertex(i)->point(), n));
        }
      }
    }
    return SortedColumns(pts, n);
  }
  // Vertex ids and coordinates.
  std::map<const void*, int> id;
  Mat coords(n, static_cast<Eigen::Index>(tri.number_of_vertices()));
  for (auto v = tri.finite_vertices_begin(); v != tri.finite_vertices_end(); ++v) {
    const int k = static_cast<int>(id.size());
    id[&*v] = k;
    coords.col(k) = ToVec(v->point(), n);
  }
  // Boundary facets: the finite facets of the infinite cells; neighbours across their ridges are
  // infinite cells too.
  std::vector<Triangulation::Full_cell_const_handle> cells;
  tri.incident_full_cells(tri.infinite_vertex(), std::back_inserter(cells));
  std::vector<int> facets;
  std::vector<char> flat;
  facets.reserve(cells.size() * std::size_t(d));
  const auto in_affine_hull = tri.geom_traits().contained_in_affine_hull_d_object();
  std::vector<PointD> facet_points;
  StopPoll poll(stop, kFacetsPerPoll);
  for (const auto& c : cells) {
    if (poll.Raised()) return std::nullopt;
    facet_points.clear();
    for (int i = 0; i <= d; ++i) {
      if (!tri.is_infinite(c->vertex(i))) facet_points.push_back(c->vertex(i)->point());
    }
    for (int i = 0; i <= d; ++i) {
      if (tri.is_infinite(c->vertex(i))) continue;
      facets.push_back(id.at(&*c->vertex(i)));
      const auto g = c->neighbor(i);
      const auto w = g->vertex(c->mirror_index(i));
      Demand(!tri.is_infinite(w), "the neighbour of a boundary facet has no finite apex");
      flat.push_back(in_affine_hull(facet_points.begin(), facet_points.end(), w->point()) ? 1 : 0);
    }
  }
  return ExtremeBoundaryVertices(n, d, facets, flat, coords, stop);
}

// Exact orientation of n + 1 points of R^n (the sign conventions of the policies may differ; a star
// only compares signs from its own policy).
struct Geometry3 {
  using Point = Epick::Point_3;
  explicit Geometry3(int /*n*/) {}
  Point Make(const double* x) const { return Point(x[0], x[1], x[2]); }
  CGAL::Orientation Orient(const Point* const* p) const {
    return CGAL::orientation(*p[0], *p[1], *p[2], *p[3]);
  }
};

template <class DimensionTag>
struct GeometryT {
  using Kernel = CGAL::Epick_d<DimensionTag>;
  using Point = typename Kernel::Point_d;
  explicit GeometryT(int n) : n_(n) {}
  Point Make(const double* x) const { return Point(x, x + n_); }
  CGAL::Orientation Orient(const Point* const* p) const {
    return kernel_.orientation_d_object()(boost::make_indirect_iterator(p),
                                          boost::make_indirect_iterator(p + n_ + 1));
  }
  int n_;
  Kernel kernel_;
};

class Star {
 public:
  virtual ~Star() = default;
  virtual bool Add(const double* x) = 0;
  virtual bool Contains(const double* x) const = 0;
  virtual double SquaredDistance(const Vec& x) const = 0;
  virtual std::optional<double> Volume(const std::atomic<bool>* stop) const = 0;
  virtual std::optional<Mat> Vertices(const std::atomic<bool>* stop) const = 0;
  virtual std::vector<Mat> Simplices() const = 0;
};

// The star of the hull boundary from c (see the top of the file). Facet f has vertices
// fv_[f·n + i] ordered so that Orient(F, c) is POSITIVE, and neighbour fn_[f·n + i] across the ridge
// opposite slot i.
template <class Geometry>
class StarHull final : public Star {
 public:
  using Point = typename Geometry::Point;
  using Pointers = boost::container::small_vector<const Point*, 9>;

  // simplex: n × (n + 1) affinely independent points; c strictly inside it.
  StarHull(int n, const Mat& simplex, const Vec& c)
      : n_(n), geometry_(n), c_(geometry_.Make(c.data())), c_coords_(c) {
    for (int j = 0; j <= n; ++j) AddPoint(simplex.col(j).data());
    // Facet j: every vertex but j; across the ridge opposite the slot of vertex k lies facet k.
    std::vector<int> ids;
    for (int j = 0; j <= n; ++j) {
      ids.clear();
      for (int k = 0; k <= n; ++k) {
        if (k != j) ids.push_back(k);
      }
      const int f = NewFacet(ids.data());
      Demand(f == j, "facet numbering of the first simplex");
    }
    for (int j = 0; j <= n; ++j) {
      for (int i = 0; i < n; ++i) Neighbour(j, i) = Vertex(j, i);  // vertex k ↔ facet k
    }
    hint_ = 0;
  }

  bool Add(const double* x) override {
    const Point q = geometry_.Make(x);
    const int f = Walk(q, hint_);
    if (Side(f, q) != CGAL::NEGATIVE) {
      hint_ = f;
      return false;
    }
    Insert(x, q, f);
    return true;
  }

  bool Contains(const double* x) const override {
    const Point q = geometry_.Make(x);
    return Side(Walk(q, hint_), q) != CGAL::NEGATIVE;
  }

  double SquaredDistance(const Vec& x) const override {
    if (Contains(x.data())) return 0.0;
    double best = std::numeric_limits<double>::infinity();
    Mat v(n_, n_);
    for (int f = 0; f < facet_slots(); ++f) {
      if (!alive_[std::size_t(f)]) continue;
      for (int i = 0; i < n_; ++i) v.col(i) = Coords(Vertex(f, i));
      best = std::min(best, SquaredDistanceToSimplex(x, v));
    }
    return best;
  }

  std::optional<double> Volume(const std::atomic<bool>* stop) const override {
    double sum = 0.0;
    Mat e(n_, n_);
    StopPoll poll(stop, kFacetsPerPoll);
    for (int f = 0; f < facet_slots(); ++f) {
      if (!alive_[std::size_t(f)]) continue;
      if (poll.Raised()) return std::nullopt;
      for (int i = 0; i < n_; ++i) e.col(i) = Coords(Vertex(f, i)) - c_coords_;
      sum += std::abs(e.determinant());
    }
    return sum / Factorial(n_);
  }

  std::optional<Mat> Vertices(const std::atomic<bool>* stop) const override {
    // Facets and, per ridge, whether the neighbour's apex is coplanar with the facet.
    std::vector<int> facets;
    std::vector<char> flat;
    Pointers p(std::size_t(n_ + 1));
    StopPoll poll(stop, kFacetsPerPoll);
    for (int f = 0; f < facet_slots(); ++f) {
      if (!alive_[std::size_t(f)]) continue;
      if (poll.Raised()) return std::nullopt;
      for (int i = 0; i < n_; ++i) p[std::size_t(i)] = &points_[std::size_t(Vertex(f, i))];
      for (int i = 0; i < n_; ++i) {
        facets.push_back(Vertex(f, i));
        const int g = Neighbour(f, i);
        if (g < f) {  // each ridge once: flat marks the ridge's vertices, from either side
          flat.push_back(0);
          continue;
        }
        p[std::size_t(n_)] = &points_[std::size_t(Apex(g, f))];
        flat.push_back(geometry_.Orient(p.data()) == CGAL::ZERO ? 1 : 0);
      }
    }
    const Eigen::Map<const Mat> coords(coords_.data(), n_, static_cast<Eigen::Index>(points_.size()));
    return ExtremeBoundaryVertices(n_, n_, facets, flat, coords, stop);
  }

  std::vector<Mat> Simplices() const override {
    std::vector<Mat> out;
    for (int f = 0; f < facet_slots(); ++f) {
      if (!alive_[std::size_t(f)]) continue;
      Mat s(n_, n_ + 1);
      s.col(0) = c_coords_;
      for (int i = 0; i < n_; ++i) s.col(i + 1) = Coords(Vertex(f, i));
      out.push_back(std::move(s));
    }
    return out;
  }

 private:
  int facet_slots() const { return static_cast<int>(alive_.size()); }
  int& Vertex(int f, int i) { return fv_[std::size_t(f) * std::size_t(n_) + std::size_t(i)]; }
  int Vertex(int f, int i) const { return fv_[std::size_t(f) * std::size_t(n_) + std::size_t(i)]; }
  int& Neighbour(int f, int i) { return fn_[std::size_t(f) * std::size_t(n_) + std::size_t(i)]; }
  int Neighbour(int f, int i) const { return fn_[std::size_t(f) * std::size_t(n_) + std::size_t(i)]; }
  Eigen::Map<const Vec> Coords(int v) const {
    return Eigen::Map<const Vec>(coords_.data() + std::size_t(v) * std::size_t(n_), n_);
  }

  int AddPoint(const double* x) {
    points_.push_back(geometry_.Make(x));
    coords_.insert(coords_.end(), x, x + n_);
    return static_cast<int>(points_.size()) - 1;
  }

  // The vertex of facet g that is not in its neighbour f (g's slot whose neighbour is f).
  int Apex(int g, int f) const { return Vertex(g, SlotOf(g, f)); }
  int SlotOf(int g, int f) const {
    for (int i = 0; i < n_; ++i) {
      if (Neighbour(g, i) == f) return i;
    }
    Demand(false, "facets that should be neighbours are not");
    return -1;
  }

  // Orient(F, q): NEGATIVE when q is strictly beyond facet f (c is on its POSITIVE side).
  CGAL::Orientation Side(int f, const Point& q) const {
    Pointers p(std::size_t(n_ + 1));
    for (int i = 0; i < n_; ++i) p[std::size_t(i)] = &points_[std::size_t(Vertex(f, i))];
    p[std::size_t(n_)] = &q;
    return geometry_.Orient(p.data());
  }

  // A new facet with vertices ids[0..n), ordered so that c is on its positive side.
  int NewFacet(const int* ids) {
    int f;
    if (!free_.empty()) {
      f = free_.back();
      free_.pop_back();
      alive_[std::size_t(f)] = 1;
    } else {
      f = facet_slots();
      alive_.push_back(1);
      fv_.resize(fv_.size() + std::size_t(n_));
      fn_.resize(fn_.size() + std::size_t(n_), -1);
      seen_.push_back(0);
      visible_flag_.push_back(0);
    }
    for (int i = 0; i < n_; ++i) Vertex(f, i) = ids[i];
    const CGAL::Orientation o = Side(f, c_);
    Demand(o != CGAL::ZERO, "a boundary facet through the interior reference point");
    if (o == CGAL::NEGATIVE) std::swap(Vertex(f, 0), Vertex(f, 1));
    return f;
  }

  // A facet whose cone from c holds q: remembering stochastic visibility walk from `start` (each
  // step leaves through a ridge whose plane through c separates q from the facet; the ridge order
  // is random, which makes the walk end in any triangulation). Deterministic: the generator is
  // seeded per walk. Falls back to a scan of all facets after a generous step count.
  int Walk(const Point& q, int start) const {
    std::uint64_t rng = 0x9E3779B97F4A7C15ULL;
    int f = start, previous = -1;
    Pointers p(std::size_t(n_ + 1));
    const long limit = 16L * facet_slots() + 64;
    for (long step = 0; step < limit; ++step) {
      rng ^= rng << 13;
      rng ^= rng >> 7;
      rng ^= rng << 17;
      const int first = static_cast<int>(rng % std::uint64_t(n_));
      for (int i = 0; i < n_; ++i) p[std::size_t(i)] = &points_[std::size_t(Vertex(f, i))];
      p[std::size_t(n_)] = &q;
      int next = -1;
      for (int k = 0; k < n_; ++k) {
        const int i = (first + k) % n_;
        const int g = Neighbour(f, i);
        if (g == previous) continue;  // q is on this side of the ridge we came through
        // Vertex i replaced by c: POSITIVE when q and vertex i are on opposite sides of the
        // ridge's plane through c (the swap of c and vertex i flips Orient(F, c) = POSITIVE).
        const Point* vi = p[std::size_t(i)];
        p[std::size_t(i)] = &c_;
        const CGAL::Orientation o = geometry_.Orient(p.data());
        p[std::size_t(i)] = vi;
        if (o == CGAL::POSITIVE) {
          next = g;
          break;
        }
      }
      if (next < 0) return f;
      previous = f;
      f = next;
    }
    return Scan(q);
  }

  int Scan(const Point& q) const {
    Pointers p(std::size_t(n_ + 1));
    for (int f = 0; f < facet_slots(); ++f) {
      if (!alive_[std::size_t(f)]) continue;
      for (int i = 0; i < n_; ++i) p[std::size_t(i)] = &points_[std::size_t(Vertex(f, i))];
      p[std::size_t(n_)] = &q;
      bool in_cone = true;
      for (int i = 0; i < n_ && in_cone; ++i) {
        const Point* vi = p[std::size_t(i)];
        p[std::size_t(i)] = &c_;
        in_cone = geometry_.Orient(p.data()) != CGAL::POSITIVE;
        p[std::size_t(i)] = vi;
      }
      if (in_cone) return f;
    }
    Demand(false, "no cone of the hull holds the point");
    return -1;
  }

  // q (coordinates x) is strictly beyond facet f0.
  void Insert(const double* x, const Point& q, int f0) {
    const int id = AddPoint(x);
    // The facets q sees: connected, found by a search from f0.
    ++stamp_;
    visible_.clear();
    visible_.push_back(f0);
    seen_[std::size_t(f0)] = stamp_;
    visible_flag_[std::size_t(f0)] = 1;
    for (std::size_t k = 0; k < visible_.size(); ++k) {
      const int f = visible_[k];
      for (int i = 0; i < n_; ++i) {
        const int g = Neighbour(f, i);
        if (seen_[std::size_t(g)] == stamp_) continue;
        seen_[std::size_t(g)] = stamp_;
        const bool sees = Side(g, q) == CGAL::NEGATIVE;
        visible_flag_[std::size_t(g)] = sees ? 1 : 0;
        if (sees) visible_.push_back(g);
      }
    }
    // One new facet per horizon ridge (a ridge between a visible and a hidden facet): the ridge
    // joined to q. Across the ridge lies the hidden facet.
    created_.clear();
    std::vector<int> ids(static_cast<std::size_t>(n_));
    for (const int f : visible_) {
      for (int i = 0; i < n_; ++i) {
        const int g = Neighbour(f, i);
        if (visible_flag_[std::size_t(g)]) continue;
        for (int j = 0; j < n_; ++j) ids[std::size_t(j)] = j == i ? id : Vertex(f, j);
        const int h = NewFacet(ids.data());
        const int q_slot = Vertex(h, i) == id ? i : (Vertex(h, 0) == id ? 0 : 1);  // NewFacet may swap 0, 1
        Neighbour(h, q_slot) = g;
        Neighbour(g, SlotOf(g, f)) = h;
        created_.push_back(h);
      }
    }
    // The new facets' other ridges (those through q) pair up among themselves. n = 3: a ridge is
    // {q, u}, matched through a slot per vertex u; else by sorted vertex ids.
    if (n_ == 3) {
      if (pending_.size() < points_.size()) {
        pending_.resize(points_.size(), Pending{});
      }
      for (const int h : created_) {
        for (int i = 0; i < 3; ++i) {
          if (Vertex(h, i) == id) continue;
          const int u = Vertex(h, (i + 1) % 3) == id ? Vertex(h, (i + 2) % 3) : Vertex(h, (i + 1) % 3);
          Pending& p = pending_[std::size_t(u)];
          if (p.stamp != stamp_) {
            p = {stamp_, h, i};
            continue;
          }
          Demand(p.facet >= 0, "a ridge through the new vertex shared by other than two facets");
          Neighbour(h, i) = p.facet;
          Neighbour(p.facet, p.slot) = h;
          p.facet = -1;
        }
      }
    } else {
      MatchRidges(id);
    }
    for (const int f : visible_) {
      alive_[std::size_t(f)] = 0;
      free_.push_back(f);
    }
    hint_ = created_.front();
  }

  // Pairs the ridges through the new vertex `id` among the new facets: by the other n − 2 vertex
  // ids, sorted (n = 4: the two packed into one integer).
  void MatchRidges(int id) {
    const std::size_t width = std::size_t(n_ - 2);
    keys_.clear();
    entries_.clear();
    for (const int h : created_) {
      for (int i = 0; i < n_; ++i) {
        if (Vertex(h, i) == id) continue;
        const std::size_t at = keys_.size();
        for (int j = 0; j < n_; ++j) {
          if (j != i && Vertex(h, j) != id) keys_.push_back(Vertex(h, j));
        }
        std::sort(keys_.begin() + std::ptrdiff_t(at), keys_.end());
        const std::uint64_t packed =
            n_ == 4 ? (std::uint64_t(std::uint32_t(keys_[at])) << 32) | std::uint32_t(keys_[at + 1]) : 0;
        entries_.push_back({h, i, at, packed});
      }
    }
    const auto key = [&](const Entry& e) { return keys_.begin() + std::ptrdiff_t(e.key); };
    std::sort(entries_.begin(), entries_.end(), [&](const Entry& a, const Entry& b) {
      if (n_ == 4) return a.packed < b.packed;
      return std::lexicographical_compare(key(a), key(a) + std::ptrdiff_t(width), key(b),
                                          key(b) + std::ptrdiff_t(width));
    });
    Demand(entries_.size() % 2 == 0, "an unpaired ridge on the horizon");
    for (std::size_t k = 0; k < entries_.size(); k += 2) {
      const Entry& a = entries_[k];
      const Entry& b = entries_[k + 1];
      Demand(std::equal(key(a), key(a) + std::ptrdiff_t(width), key(b)) &&
                 (k + 2 >= entries_.size() ||
                  !std::equal(key(a), key(a) + std::ptrdiff_t(width), key(entries_[k + 2]))),
             "a ridge through the new vertex shared by other than two facets");
      Neighbour(a.facet, a.slot) = b.facet;
      Neighbour(b.facet, b.slot) = a.facet;
    }
  }

  struct Entry {
    int facet, slot;
    std::size_t key;       // offset in keys_
    std::uint64_t packed;  // n = 4: both key ids
  };
  struct Pending {  // n = 3: the first new facet met on the ridge {q, u}, by u
    unsigned stamp = 0;
    int facet = -1, slot = -1;
  };

  int n_;
  Geometry geometry_;
  Point c_;
  Vec c_coords_;
  std::vector<Point> points_;   // every point ever inserted (vertex id = index)
  std::vector<double> coords_;  // the same, n doubles each
  std::vector<int> fv_, fn_;
  std::vector<char> alive_;
  std::vector<int> free_;
  int hint_ = 0;
  // Scratch of Insert.
  unsigned stamp_ = 0;
  std::vector<unsigned> seen_;
  std::vector<char> visible_flag_;
  std::vector<int> visible_, created_, keys_;
  std::vector<Entry> entries_;
  std::vector<Pending> pending_;
};

}  // namespace

struct HullNd::Impl {
  explicit Impl(int dim) : n(dim), tri(dim), face(dim) {}

  // Early phase: after an insertion that made (or kept) the hull n-dimensional, look for a reference
  // point among the new vertex's cells: the rounded centroid, if strictly inside its cell. Every
  // cell is incident to the vertex that created it, so each cell is tried once.
  void TryStar(Triangulation::Vertex_handle v) {
    std::vector<Triangulation::Full_cell_handle> cells;
    tri.incident_full_cells(v, std::back_inserter(cells));
    const auto orient = tri.geom_traits().orientation_d_object();
    std::vector<PointD> p(std::size_t(n + 1));
    for (const auto& cell : cells) {
      if (tri.is_infinite(cell)) continue;
      Mat simplex(n, n + 1);
      for (int j = 0; j <= n; ++j) {
        p[std::size_t(j)] = cell->vertex(j)->point();
        simplex.col(j) = ToVec(p[std::size_t(j)], n);
      }
      const Vec c = simplex.rowwise().mean();
      const CGAL::Orientation o = orient(p.begin(), p.end());
      bool inside = o != CGAL::ZERO;
      for (int j = 0; j <= n && inside; ++j) {
        const PointD keep = p[std::size_t(j)];
        p[std::size_t(j)] = ToPointD(c.data(), n);
        inside = orient(p.begin(), p.end()) == o;
        p[std::size_t(j)] = keep;
      }
      if (!inside) continue;
      if (n == 3) {
        star = std::make_unique<StarHull<Geometry3>>(n, simplex, c);
      } else if (n == 4) {
        star = std::make_unique<StarHull<GeometryT<CGAL::Dimension_tag<4>>>>(n, simplex, c);
      } else {
        star = std::make_unique<StarHull<GeometryT<CGAL::Dynamic_dimension_tag>>>(n, simplex, c);
      }
      // The other vertices (inside ones change nothing), in the triangulation's order.
      for (auto u = tri.finite_vertices_begin(); u != tri.finite_vertices_end(); ++u) {
        const Vec x = ToVec(u->point(), n);
        star->Add(x.data());
      }
      tri.clear();
      hint = Triangulation::Full_cell_handle();
      return;
    }
  }

  int n;
  Triangulation tri;  // early phase (star is null)
  Triangulation::Full_cell_handle hint;
  Triangulation::Face face;
  Triangulation::Facet facet;
  std::unique_ptr<Star> star;
};

HullNd::HullNd(int n) : impl_(std::make_unique<Impl>(n)) {}
HullNd::~HullNd() = default;

bool HullNd::Add(const ConstVecRef& x) {
  Impl& s = *impl_;
  if (s.star) return s.star->Add(x.data());
  const PointD p = ToPointD(x.data(), s.n);
  Triangulation::Locate_type lt;
  const auto cell = s.tri.locate(p, lt, s.face, s.facet, s.hint);
  if (!Outside(lt)) {
    s.hint = cell;
    return false;
  }
  const auto v = s.tri.insert(p, lt, s.face, s.facet, cell);
  s.hint = v->full_cell();
  if (s.tri.current_dimension() == s.n) s.TryStar(v);
  return true;
}

int HullNd::dimension() const { return impl_->star ? impl_->n : impl_->tri.current_dimension(); }

std::optional<Mat> HullNd::Vertices(const std::atomic<bool>* stop) const {
  const Impl& s = *impl_;
  return s.star ? s.star->Vertices(stop) : TriangulationExtremePoints(s.tri, s.n, stop);
}

bool HullNd::Contains(const ConstVecRef& x) const {
  const Impl& s = *impl_;
  if (s.star) return s.star->Contains(x.data());
  if (s.tri.current_dimension() < 0) return false;
  Triangulation::Locate_type lt;
  Triangulation::Face face(s.n);
  Triangulation::Facet facet;
  s.tri.locate(ToPointD(x.data(), s.n), lt, face, facet, s.hint);
  return !Outside(lt);
}

double HullNd::SquaredDistance(const ConstVecRef& x) const {
  const Impl& s = *impl_;
  const Vec q = x;
  if (s.star) return s.star->SquaredDistance(q);
  const int d = s.tri.current_dimension();
  if (d < 0) return std::numeric_limits<double>::infinity();
  if (Contains(x)) return 0.0;
  // Full-dimensional: the nearest boundary facet (finite facets of the infinite cells). Lower-
  // dimensional: the nearest cell (the nearest point may be in the hull's relative interior).
  double best = std::numeric_limits<double>::infinity();
  for (auto c = s.tri.full_cells_begin(); c != s.tri.full_cells_end(); ++c) {
    const bool infinite = s.tri.is_infinite(c);
    if (d == s.n ? !infinite : infinite) continue;
    std::vector<Vec> cols;
    for (int i = 0; i <= d; ++i) {
      if (!s.tri.is_infinite(c->vertex(i))) cols.push_back(ToVec(c->vertex(i)->point(), s.n));
    }
    Mat v(s.n, static_cast<Eigen::Index>(cols.size()));
    for (std::size_t i = 0; i < cols.size(); ++i) v.col(Eigen::Index(i)) = cols[i];
    best = std::min(best, SquaredDistanceToSimplex(q, v));
  }
  return best;
}

std::optional<double> HullNd::Volume(const std::atomic<bool>* stop) const {
  const Impl& s = *impl_;
  if (s.star) return s.star->Volume(stop);
  if (s.tri.current_dimension() < s.n) return 0.0;
  double sum = 0.0;
  Mat e(s.n, s.n);
  StopPoll poll(stop, kFacetsPerPoll);
  for (auto c = s.tri.finite_full_cells_begin(); c != s.tri.finite_full_cells_end(); ++c) {
    if (poll.Raised()) return std::nullopt;
    const Vec v0 = ToVec(c->vertex(0)->point(), s.n);
    for (int i = 1; i <= s.n; ++i) e.col(i - 1) = ToVec(c->vertex(i)->point(), s.n) - v0;
    sum += std::abs(e.determinant());
  }
  return sum / Factorial(s.n);
}

std::vector<Mat> HullNd::Simplices() const {
  const Impl& s = *impl_;
  if (s.star) return s.star->Simplices();
  const int d = s.tri.current_dimension();
  std::vector<Mat> out;
  if (d < 0) return out;
  if (d == 0) {
    out.push_back(ToVec(s.tri.finite_vertices_begin()->point(), s.n));
    return out;
  }
  for (auto c = s.tri.finite_full_cells_begin(); c != s.tri.finite_full_cells_end(); ++c) {
    Mat m(s.n, d + 1);
    for (int i = 0; i <= d; ++i) m.col(i) = ToVec(c->vertex(i)->point(), s.n);
    out.push_back(std::move(m));
  }
  return out;
}

Mat BatchExtremePoints(const Mat& points) {
  const int n = static_cast<int>(points.rows());
  if (n == 3) {
    std::vector<Epick::Point_3> in, out;
    in.reserve(static_cast<std::size_t>(points.cols()));
    for (Eigen::Index k = 0; k < points.cols(); ++k)
      in.emplace_back(points(0, k), points(1, k), points(2, k));
    if (!in.empty()) CGAL::extreme_points_3(in, std::back_inserter(out));
    std::vector<Vec> cols;
    for (const auto& p : out) cols.push_back((Vec(3) << p.x(), p.y(), p.z()).finished());
    return SortedColumns(cols, 3);
  }
  Triangulation tri(n);
  std::vector<PointD> in;
  in.reserve(static_cast<std::size_t>(points.cols()));
  for (Eigen::Index k = 0; k < points.cols(); ++k) in.push_back(ToPointD(points.col(k).data(), n));
  tri.insert(in.begin(), in.end());
  return *TriangulationExtremePoints(tri, n, nullptr);
}

}  // namespace hysid::internal
