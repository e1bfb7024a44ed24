#include "core/set_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

namespace hysid {
namespace {

constexpr double kQuadraturePoints = 65536.0;

double JumpHausdorff(const Model& model, const Mat& hull) {
  if (!model.has_jump_set_distance() || hull.cols() == 0) return std::numeric_limits<double>::quiet_NaN();
  double worst = 0.0;
  for (Eigen::Index i = 0; i < hull.cols(); ++i) worst = std::max(worst, model.DistanceToJumpSet(hull.col(i)));
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

double FlowOutsideShare(const Model& model, const Mat& hull) {
  switch (hull.cols()) {
    case 0:
      return std::numeric_limits<double>::quiet_NaN();
    case 1:
      return model.InFlowSet(hull.col(0)) ? 0.0 : 1.0;
    case 2:
      return SegmentOutsideShare(model, hull.col(0), hull.col(1));
    default:
      return PolygonOutsideShare(model, hull);
  }
}

}  // namespace

SetMetrics CompareSets(const Model& model, const Mat& flow_hull, const Mat& jump_hull) {
  for (const Mat* hull : {&flow_hull, &jump_hull}) {
    if (hull->rows() != model.state_size()) {
      throw std::invalid_argument(fmt::format("CompareSets: hull vertices have {} rows; model '{}' has {} states",
                                              hull->rows(), model.name(), model.state_size()));
    }
  }
  if (flow_hull.rows() > 2) {
    throw std::invalid_argument(fmt::format("CompareSets: {} states; set metrics exist for 1 and 2",
                                            flow_hull.rows()));
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
