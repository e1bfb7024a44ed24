// The incremental convex hulls of Λ and Γ (see sample_set.hpp): 1-D and 2-D here, n ≥ 3 in
// core/sets/hull_nd.cpp. These two are the only translation units that include CGAL.
#include "core/sets/sample_set.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iterator>
#include <limits>
#include <set>
#include <stdexcept>
#include <utility>
#include <vector>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/convex_hull_2.h>
#include <fmt/format.h>

#include "core/sets/demand.hpp"
#include "core/sets/hull_nd.hpp"

namespace hysid {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_2;

// Internal invariants (style tier b): always on, abort.
void Demand(bool ok, const char* what) { sets_internal::Demand(ok, "SampleSet", what); }

bool LexLess(const Point& a, const Point& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); }

// Angular order around c, from the direction +x1 counter-clockwise. Exact: the half-plane
// (angle in [0, π) or [π, 2π)) is decided by comparing coordinates with c's, the order inside a
// half-plane by CGAL::orientation. Points equal to c are never compared.
struct AngularLess {
  Point c;
  int Half(const Point& p) const { return (p.y() < c.y() || (p.y() == c.y() && p.x() < c.x())) ? 1 : 0; }
  bool operator()(const Point& a, const Point& b) const {
    const int ha = Half(a), hb = Half(b);
    if (ha != hb) return ha < hb;
    return CGAL::orientation(c, a, b) == CGAL::LEFT_TURN;
  }
};

double SquaredDistanceToSegment(const Point& q, const Point& a, const Point& b) {
  const double dx = b.x() - a.x(), dy = b.y() - a.y();
  const double qx = q.x() - a.x(), qy = q.y() - a.y();
  const double len2 = dx * dx + dy * dy;
  double t = len2 > 0.0 ? (qx * dx + qy * dy) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  const double ex = qx - t * dx, ey = qy - t * dy;
  return ex * ex + ey * ey;
}

// Rotates a counter-clockwise vertex list so that it starts at the lexicographically smallest vertex.
void StartAtLexSmallest(std::vector<Point>& v) {
  if (v.empty()) return;
  std::rotate(v.begin(), std::min_element(v.begin(), v.end(), LexLess), v.end());
}

// The 2-D hull. dim_ −1: empty; 0: the point a_; 1: the segment a_ <lex b_; 2: a polygon, in ring_
// (angular order around ring_'s reference point) or, without a reference point, in plain_ (CCW).
class Hull2 {
 public:
  int dimension() const { return dim_; }

  // Returns true when the hull changed.
  bool Add(const Point& q) {
    switch (dim_) {
      case -1:
        a_ = q;
        dim_ = 0;
        return true;
      case 0:
        if (q == a_) return false;
        b_ = q;
        if (LexLess(b_, a_)) std::swap(a_, b_);
        dim_ = 1;
        return true;
      case 1: return AddToSegment(q);
      default: return has_reference_ ? AddToRing(q) : AddToPlain(q);
    }
  }

  bool Contains(const Point& q) const {
    switch (dim_) {
      case -1: return false;
      case 0: return q == a_;
      case 1: return CGAL::orientation(a_, b_, q) == CGAL::COLLINEAR && !LexLess(q, a_) && !LexLess(b_, q);
      default:
        if (!has_reference_) return PlainContains(q);
        if (q == center()) return true;
        {
          const Ring::const_iterator v = WedgeEnd(q);
          return CGAL::orientation(*Prev(v), *v, q) != CGAL::RIGHT_TURN;
        }
    }
  }

  // Squared Euclidean distance from q to the hull (0 inside). Floating point.
  double SquaredDistance(const Point& q) const {
    if (Contains(q)) return 0.0;
    switch (dim_) {
      case -1: return std::numeric_limits<double>::infinity();
      case 0: return SquaredDistanceToSegment(q, a_, a_);
      case 1: return SquaredDistanceToSegment(q, a_, b_);
      default: {
        const std::vector<Point> v = Vertices();
        double best = std::numeric_limits<double>::infinity();
        for (std::size_t i = 0; i < v.size(); ++i) {
          best = std::min(best, SquaredDistanceToSegment(q, v[i], v[(i + 1) % v.size()]));
        }
        return best;
      }
    }
  }

  std::vector<Point> Vertices() const {
    std::vector<Point> v;
    switch (dim_) {
      case -1: break;
      case 0: v = {a_}; break;
      case 1: v = {a_, b_}; break;
      default:
        if (has_reference_) {
          v.assign(ring_.begin(), ring_.end());
        } else {
          v = plain_;
        }
        StartAtLexSmallest(v);
    }
    return v;
  }

 private:
  using Ring = std::set<Point, AngularLess>;
  using It = Ring::const_iterator;

  const Point& center() const { return center_; }
  It Next(It it) const {
    ++it;
    return it == ring_.end() ? ring_.begin() : it;
  }
  It Prev(It it) const { return std::prev(it == ring_.begin() ? ring_.end() : it); }

  // The end v of the angular wedge (Prev(v), v] that holds q ≠ c: a binary search, O(log h).
  It WedgeEnd(const Point& q) const {
    const It it = ring_.lower_bound(q);
    return it == ring_.end() ? ring_.begin() : it;
  }

  // A wedge (a, v] between consecutive vertices a = Prev(v) and v.
  struct Wedge {
    It a, v;
  };

  // The same, first walking a few wedges from the previous sample's (consecutive samples of a
  // trajectory are usually in the same or a neighbouring wedge), then by binary search.
  Wedge LocateFromFinger(const Point& q) const {
    static constexpr int kWalk = 4;
    const Point& c = center();
    Wedge w = finger_;
    for (int step = 0; step < kWalk; ++step) {
      if (CGAL::orientation(c, *w.a, q) != CGAL::LEFT_TURN) {
        w = {Prev(w.a), w.a};  // q is clockwise of (or on) the ray c→a
      } else if (CGAL::orientation(c, *w.v, q) == CGAL::LEFT_TURN) {
        w = {w.v, Next(w.v)};  // q is counter-clockwise of the ray c→v
      } else {
        return w;  // the wedge (a, v] (its angle is below π: c is strictly inside)
      }
    }
    const It v = WedgeEnd(q);
    return {Prev(v), v};
  }

  bool AddToSegment(const Point& q) {
    const CGAL::Orientation o = CGAL::orientation(a_, b_, q);
    if (o == CGAL::COLLINEAR) {
      if (LexLess(q, a_)) {
        a_ = q;
        return true;
      }
      if (LexLess(b_, q)) {
        b_ = q;
        return true;
      }
      return false;
    }
    // Promotion: the first non-collinear sample makes a triangle.
    dim_ = 2;
    std::vector<Point> triangle =
        o == CGAL::LEFT_TURN ? std::vector<Point>{a_, b_, q} : std::vector<Point>{a_, q, b_};
    plain_ = std::move(triangle);
    has_reference_ = false;
    TryReference();
    return true;
  }

  bool AddToRing(const Point& q) {
    const Point c = center();
    if (q == c) return false;
    const Wedge w = LocateFromFinger(q);
    if (CGAL::orientation(*w.a, *w.v, q) != CGAL::RIGHT_TURN) {
      finger_ = w;
      return false;  // inside or on the boundary
    }
    It v = w.v;
    // q is outside. On the ray c→v beyond v, v becomes interior: q takes its place.
    if (CGAL::orientation(c, *v, q) == CGAL::COLLINEAR) {
      v = ring_.erase(v);
      if (v == ring_.end()) v = ring_.begin();
    }
    // q goes just before v (after the last vertex when its wedge wraps around angle 0): an
    // amortised O(1) insertion at the hint.
    const It hint = ring_.key_comp()(*v, q) ? ring_.end() : v;
    const std::size_t before = ring_.size();
    const It it = ring_.emplace_hint(hint, q);
    Demand(ring_.size() == before + 1, "a new hull vertex has the angle of an existing one");
    // Remove the vertices that q makes reflex (or flat), on both sides; the reference point stays
    // strictly inside, so at least three vertices remain.
    while (ring_.size() > 3) {
      const It s = Next(it), ss = Next(s);
      if (CGAL::orientation(q, *s, *ss) == CGAL::LEFT_TURN) break;
      ring_.erase(s);
    }
    while (ring_.size() > 3) {
      const It p = Prev(it), pp = Prev(p);
      if (CGAL::orientation(*pp, *p, q) == CGAL::LEFT_TURN) break;
      ring_.erase(p);
    }
    finger_ = {Prev(it), it};
    return true;
  }

  bool PlainContains(const Point& q) const {
    for (std::size_t i = 0; i < plain_.size(); ++i) {
      if (CGAL::orientation(plain_[i], plain_[(i + 1) % plain_.size()], q) == CGAL::RIGHT_TURN) {
        return false;
      }
    }
    return true;
  }

  bool AddToPlain(const Point& q) {
    if (PlainContains(q)) return false;
    std::vector<Point> points = plain_;
    points.push_back(q);
    plain_.clear();
    CGAL::convex_hull_2(points.begin(), points.end(), std::back_inserter(plain_));
    TryReference();
    return true;
  }

  // Moves plain_ into ring_ when the rounded centroid of three of its vertices is strictly inside
  // their triangle (always, but for triangles only a few units in the last place wide).
  void TryReference() {
    const std::size_t h = plain_.size();
    Demand(h >= 3, "a 2-D hull with fewer than 3 vertices");
    const Point& p0 = plain_[0];
    const Point& p1 = plain_[h / 3];
    const Point& p2 = plain_[(2 * h) / 3];
    const Point c((p0.x() + p1.x() + p2.x()) / 3.0, (p0.y() + p1.y() + p2.y()) / 3.0);
    if (CGAL::orientation(p0, p1, c) != CGAL::LEFT_TURN || CGAL::orientation(p1, p2, c) != CGAL::LEFT_TURN ||
        CGAL::orientation(p2, p0, c) != CGAL::LEFT_TURN) {
      return;
    }
    center_ = c;
    ring_ = Ring(AngularLess{c});
    ring_.insert(plain_.begin(), plain_.end());
    Demand(ring_.size() == h, "hull vertices with equal angles around an interior point");
    plain_.clear();
    finger_ = {Prev(ring_.begin()), ring_.begin()};
    has_reference_ = true;
  }

  int dim_ = -1;
  Point a_, b_;
  bool has_reference_ = false;
  Point center_{0.0, 0.0};  // the reference point of ring_ (a copy of its comparator's)
  Ring ring_{AngularLess{Point(0.0, 0.0)}};
  Wedge finger_;  // the previous sample's wedge (ring_ only)
  std::vector<Point> plain_;
};

Mat ToMat(const std::vector<Point>& v) {
  Mat m(2, static_cast<Eigen::Index>(v.size()));
  for (std::size_t i = 0; i < v.size(); ++i) {
    m(0, Eigen::Index(i)) = v[i].x();
    m(1, Eigen::Index(i)) = v[i].y();
  }
  return m;
}

void RequireSupported(int dimension, const char* where) {
  if (dimension < 1) {
    throw std::invalid_argument(
        fmt::format("{}: dimension {}: a sample set needs at least one component", where, dimension));
  }
}

// The finite columns of `points`.
Mat FiniteColumns(const Mat& points) {
  Mat m(points.rows(), points.cols());
  Eigen::Index k = 0;
  for (Eigen::Index j = 0; j < points.cols(); ++j) {
    if (points.col(j).allFinite()) m.col(k++) = points.col(j);
  }
  return m.leftCols(k);
}

}  // namespace

struct SampleSet::Impl {
  int n = 2;
  long added = 0;
  long non_finite = 0;
  long version = 0;
  Hull2 hull2;                           // n = 2
  double lo = 0.0, hi = 0.0;             // n = 1 (valid when added > 0)
  std::unique_ptr<internal::HullNd> nd;  // n ≥ 3
};

SampleSet::SampleSet(int dimension) {
  RequireSupported(dimension, "SampleSet");
  impl_ = std::make_unique<Impl>();
  impl_->n = dimension;
  if (dimension >= 3) impl_->nd = std::make_unique<internal::HullNd>(dimension);
}
SampleSet::~SampleSet() = default;
SampleSet::SampleSet(SampleSet&&) noexcept = default;
SampleSet& SampleSet::operator=(SampleSet&&) noexcept = default;

void SampleSet::Add(const ConstVecRef& x) {
  Impl& s = *impl_;
  if (x.size() != s.n) {
    throw std::invalid_argument(
        fmt::format("SampleSet::Add: sample has {} components; the set has dimension {}", x.size(), s.n));
  }
  if (!x.allFinite()) {
    ++s.non_finite;
    return;
  }
  bool changed = false;
  if (s.n == 2) {
    changed = s.hull2.Add(Point(x[0], x[1]));
  } else if (s.n >= 3) {
    changed = s.nd->Add(x);
  } else if (s.added == 0) {
    s.lo = s.hi = x[0];
    changed = true;
  } else if (x[0] < s.lo) {
    s.lo = x[0];
    changed = true;
  } else if (x[0] > s.hi) {
    s.hi = x[0];
    changed = true;
  }
  ++s.added;
  if (changed) ++s.version;
}

int SampleSet::dimension() const { return impl_->n; }
long SampleSet::size() const { return impl_->added; }
long SampleSet::non_finite() const { return impl_->non_finite; }

int SampleSet::hull_dimension() const {
  const Impl& s = *impl_;
  if (s.n == 2) return s.hull2.dimension();
  if (s.n >= 3) return s.nd->dimension();
  if (s.added == 0) return -1;
  return s.lo == s.hi ? 0 : 1;
}

Mat SampleSet::vertices() const { return *vertices(nullptr); }

std::optional<Mat> SampleSet::vertices(const std::atomic<bool>* stop) const {
  const Impl& s = *impl_;
  if (s.n == 2) return ToMat(s.hull2.Vertices());
  if (s.n >= 3) return s.nd->Vertices(stop);
  const int d = hull_dimension();
  Mat m(1, d + 1);
  if (d >= 0) m(0, 0) = s.lo;
  if (d == 1) m(0, 1) = s.hi;
  return m;
}

bool SampleSet::Contains(ConstVecRef x, double tolerance) const {
  const Impl& s = *impl_;
  if (x.size() != s.n) {
    throw std::invalid_argument(
        fmt::format("SampleSet::Contains: point has {} components; the set has dimension {}", x.size(), s.n));
  }
  if (!x.allFinite()) return false;
  const double tol = std::max(tolerance, 0.0);
  if (s.n == 1) return s.added > 0 && x[0] >= s.lo - tol && x[0] <= s.hi + tol;
  if (s.n >= 3) {
    if (s.nd->Contains(x)) return true;
    return tol > 0.0 && s.nd->dimension() >= 0 && s.nd->SquaredDistance(x) <= tol * tol;
  }
  const Point q(x[0], x[1]);
  if (s.hull2.Contains(q)) return true;
  if (tol == 0.0 || s.hull2.dimension() < 0) return false;
  return s.hull2.SquaredDistance(q) <= tol * tol;
}

long SampleSet::version() const { return impl_->version; }

double SampleSet::Volume() const { return *Volume(nullptr); }

std::optional<double> SampleSet::Volume(const std::atomic<bool>* stop) const {
  const Impl& s = *impl_;
  if (s.n == 1) return s.added > 0 ? s.hi - s.lo : 0.0;
  if (s.n >= 3) return s.nd->Volume(stop);
  if (s.hull2.dimension() < 2) return 0.0;
  const std::vector<Point> v = s.hull2.Vertices();
  // Shoelace formula relative to the first vertex.
  double twice = 0.0;
  for (std::size_t i = 1; i + 1 < v.size(); ++i) {
    const double ax = v[i].x() - v[0].x(), ay = v[i].y() - v[0].y();
    const double bx = v[i + 1].x() - v[0].x(), by = v[i + 1].y() - v[0].y();
    twice += ax * by - ay * bx;
  }
  return 0.5 * twice;
}

Mat BatchHullVertices(const Mat& points) {
  RequireSupported(static_cast<int>(points.rows()), "BatchHullVertices");
  if (points.rows() == 1) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (Eigen::Index k = 0; k < points.cols(); ++k) {
      if (!std::isfinite(points(0, k))) continue;
      lo = std::min(lo, points(0, k));
      hi = std::max(hi, points(0, k));
    }
    if (lo > hi) return Mat(1, 0);
    if (lo == hi) return Mat::Constant(1, 1, lo);
    Mat m(1, 2);
    m << lo, hi;
    return m;
  }
  if (points.rows() >= 3) return internal::BatchExtremePoints(FiniteColumns(points));
  std::vector<Point> in, out;
  in.reserve(static_cast<std::size_t>(points.cols()));
  for (Eigen::Index k = 0; k < points.cols(); ++k) {
    if (points.col(k).allFinite()) in.emplace_back(points(0, k), points(1, k));
  }
  CGAL::convex_hull_2(in.begin(), in.end(), std::back_inserter(out));
  StartAtLexSmallest(out);
  return ToMat(out);
}

std::vector<Mat> HullSimplices(const Mat& points) {
  if (points.rows() < 3) {
    throw std::invalid_argument(fmt::format("HullSimplices: {} rows; implemented for n >= 3", points.rows()));
  }
  internal::HullNd hull(static_cast<int>(points.rows()));
  for (Eigen::Index k = 0; k < points.cols(); ++k) {
    if (points.col(k).allFinite()) hull.Add(points.col(k));
  }
  return hull.Simplices();
}

}  // namespace hysid
