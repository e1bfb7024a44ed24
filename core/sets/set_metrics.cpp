#include "core/sets/set_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <vector>

#include <Eigen/LU>
#include <fmt/format.h>

namespace hysid {
namespace {

constexpr double kQuadraturePoints = 65536.0;

double JumpHausdorff(const Model& model, const Mat& hull) {
  if (!model.has_jump_set_distance() || hull.cols() == 0) return std::numeric_limits<double>::quiet_NaN();
  double worst = 0.0;
  for (Eigen::Index i = 0; i < hull.cols(); ++i)
    worst = std::max(worst, model.DistanceToJumpSet(hull.col(i)));
  return worst;
}

// Share of the segment [a, b] outside C, midpoint rule.
double SegmentOutsideShare(const Model& model, ConstVecRef a, ConstVecRef b) {
  const long cells = static_cast<long>(kQuadraturePoints);
  long outside = 0;
  Vec x(a.size());
  for (long i = 0; i < cells; ++i) {
    const double s = (static_cast<double>(i) + 0.5) / static_cast<double>(cells);
    x = a + s * (b - a);
    outside += model.InFlowSet(x) ? 0 : 1;
  }
  return static_cast<double>(outside) / static_cast<double>(cells);
}

// Share of the convex polygon v (2 × h, counter-clockwise) outside C: triangle fan from v.col(0),
// each triangle split into m² congruent sub-triangles tested at their centroids.
double PolygonOutsideShare(const Model& model, const Mat& v) {
  const Eigen::Index h = v.cols();
  auto twice_area = [&](Eigen::Index i) {
    const Vec e1 = v.col(i) - v.col(0), e2 = v.col(i + 1) - v.col(0);
    return e1[0] * e2[1] - e1[1] * e2[0];
  };
  double total = 0.0;
  for (Eigen::Index i = 1; i + 1 < h; ++i) total += twice_area(i);
  if (!(total > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  double outside = 0.0;
  Vec x(2);
  for (Eigen::Index i = 1; i + 1 < h; ++i) {
    const double area = twice_area(i);
    if (area <= 0.0) continue;
    const long m = std::max(1L, static_cast<long>(std::ceil(std::sqrt(kQuadraturePoints * area / total))));
    const Vec o = v.col(0), e1 = v.col(i) - o, e2 = v.col(i + 1) - o;
    const double inv_m = 1.0 / static_cast<double>(m);
    long out = 0;
    for (long a = 0; a < m; ++a) {
      for (long b = 0; a + b < m; ++b) {
        // Upward sub-triangle (a, b), (a+1, b), (a, b+1) and, when it exists, the downward one
        // (a+1, b), (a, b+1), (a+1, b+1), in lattice units of 1/m along e1, e2.
        x = o + ((static_cast<double>(a) + 1.0 / 3.0) * inv_m) * e1 +
            ((static_cast<double>(b) + 1.0 / 3.0) * inv_m) * e2;
        out += model.InFlowSet(x) ? 0 : 1;
        if (a + b + 1 < m) {
          x = o + ((static_cast<double>(a) + 2.0 / 3.0) * inv_m) * e1 +
              ((static_cast<double>(b) + 2.0 / 3.0) * inv_m) * e2;
          out += model.InFlowSet(x) ? 0 : 1;
        }
      }
    }
    outside += area * static_cast<double>(out) / static_cast<double>(m * m);
  }
  return outside / total;
}

// The centroids of the m^d simplices of the Kuhn (Freudenthal) subdivision of
// K = {y ∈ R^d : m ≥ y1 ≥ y2 ≥ ... ≥ yd ≥ 0}, all of volume 1/d!. Each is a lattice point z with
// m − 1 ≥ z1 ≥ ... ≥ zd ≥ 0 and an order in which the d coordinates step up by one (the simplex's
// vertices are z and the points after each step); coordinates with equal z must step in index
// order, so that the simplex stays in K. The centroid adds (d − k)/(d + 1) to the coordinate that
// steps k-th. For d = 2 these are the up and down sub-triangles of PolygonOutsideShare, for d = 1
// the midpoint rule.
class KuhnCentroids {
 public:
  KuhnCentroids(int d, long m)
      : d_(d), m_(m), z_(std::size_t(d)), y_(d), run_end_(std::size_t(d)), next_(std::size_t(d)) {}

  template <class Visit>
  void ForEach(Visit&& visit) {
    Lattice(0, m_ - 1, visit);
  }

 private:
  template <class Visit>
  void Lattice(int i, long hi, Visit& visit) {
    if (i == d_) {
      // Runs of equal z: run r starts at index r's first member; next_ is the next to step.
      for (int j = 0; j < d_; ++j) {
        next_[std::size_t(j)] = (j > 0 && z_[std::size_t(j)] == z_[std::size_t(j - 1)]) ? -1 : j;
      }
      for (int j = d_ - 1; j >= 0; --j) {
        const bool last = j == d_ - 1 || next_[std::size_t(j + 1)] >= 0;
        run_end_[std::size_t(j)] = last ? j + 1 : run_end_[std::size_t(j + 1)];
      }
      Steps(0, visit);
      return;
    }
    for (long v = 0; v <= hi; ++v) {
      z_[std::size_t(i)] = v;
      Lattice(i + 1, v, visit);
    }
  }

  template <class Visit>
  void Steps(int k, Visit& visit) {
    if (k == d_) {
      visit(static_cast<const Vec&>(y_));
      return;
    }
    for (int r = 0; r < d_; ++r) {
      const int j = next_[std::size_t(r)];
      if (j < 0 || j >= run_end_[std::size_t(r)]) continue;
      y_[j] = static_cast<double>(z_[std::size_t(j)]) + static_cast<double>(d_ - k) / (d_ + 1.0);
      ++next_[std::size_t(r)];
      Steps(k + 1, visit);
      --next_[std::size_t(r)];
    }
  }

  int d_;
  long m_;
  std::vector<long> z_;
  Vec y_;
  std::vector<int> run_end_, next_;  // per run (indexed by its first coordinate; −1 elsewhere)
};

// Share of a triangulated hull (simplices of one dimension d, n × (d + 1) each, n ≥ 3) outside C:
// each simplex split into m^d equal-volume sub-simplices (KuhnCentroids, mapped affinely by
// y ↦ v0 + Σ_j (y_j / m)(v_{j+1} − v_j)), m^d ≈ kQuadraturePoints × its share of the d-volume,
// tested at their centroids.
double SimplicesOutsideShare(const Model& model, const std::vector<Mat>& simplices) {
  if (simplices.empty()) return std::numeric_limits<double>::quiet_NaN();
  const int d = static_cast<int>(simplices.front().cols()) - 1;
  if (d == 0) return model.InFlowSet(simplices.front().col(0)) ? 0.0 : 1.0;
  double factorial = 1.0;
  for (int k = 2; k <= d; ++k) factorial *= k;
  std::vector<double> volume;
  double total = 0.0;
  for (const Mat& v : simplices) {
    const Mat e = v.rightCols(d).colwise() - v.col(0);
    volume.push_back(std::sqrt(std::max(0.0, (e.transpose() * e).determinant())) / factorial);
    total += volume.back();
  }
  if (!(total > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  double outside = 0.0;
  Vec x(simplices.front().rows());
  for (std::size_t s = 0; s < simplices.size(); ++s) {
    if (volume[s] <= 0.0) continue;
    const Mat& v = simplices[s];
    const long m =
        std::max(1L, static_cast<long>(std::ceil(std::pow(kQuadraturePoints * volume[s] / total, 1.0 / d))));
    const Mat steps = (v.rightCols(d) - v.leftCols(d)) / static_cast<double>(m);
    long cells = 0, out = 0;
    KuhnCentroids(d, m).ForEach([&](const Vec& y) {
      x = v.col(0) + steps * y;
      out += model.InFlowSet(x) ? 0 : 1;
      ++cells;
    });
    long expected = 1;
    for (int k = 0; k < d; ++k) expected *= m;
    if (cells != expected) {  // internal invariant: the subdivision has m^d cells
      std::fprintf(stderr, "hysid: internal error in CompareSets: %ld Kuhn cells, expected %ld\n", cells,
                   expected);
      std::abort();
    }
    outside += volume[s] * static_cast<double>(out) / static_cast<double>(cells);
  }
  return outside / total;
}

double FlowOutsideShare(const Model& model, const Mat& hull) {
  if (hull.rows() >= 3) {
    return hull.cols() == 0 ? std::numeric_limits<double>::quiet_NaN()
                            : SimplicesOutsideShare(model, HullSimplices(hull));
  }
  switch (hull.cols()) {
    case 0: return std::numeric_limits<double>::quiet_NaN();
    case 1: return model.InFlowSet(hull.col(0)) ? 0.0 : 1.0;
    case 2: return SegmentOutsideShare(model, hull.col(0), hull.col(1));
    default: return PolygonOutsideShare(model, hull);
  }
}

}  // namespace

SetMetrics CompareSets(const Model& model, const Mat& flow_hull, const Mat& jump_hull) {
  for (const Mat* hull : {&flow_hull, &jump_hull}) {
    if (hull->rows() != model.state_size()) {
      throw std::invalid_argument(
          fmt::format("CompareSets: hull vertices have {} rows; model '{}' has {} states", hull->rows(),
                      model.name(), model.state_size()));
    }
  }
  SetMetrics m;
  m.jump_hausdorff = JumpHausdorff(model, jump_hull);
  m.flow_outside_share = FlowOutsideShare(model, flow_hull);
  return m;
}

SetMetrics CompareSets(const Model& model, const SampleSet& flow_set, const SampleSet& jump_set) {
  return CompareSets(model, flow_set.vertices(), jump_set.vertices());
}

}  // namespace hysid
