// The convex hull behind SampleSet for n ≥ 3 state components (the contract and the method are in
// core/sets/sample_set.hpp). Internal to hysid_sets: only core/sets/sample_set.cpp includes this header, and
// CGAL stays in core/sets/hull_nd.cpp.
#pragma once

#include <atomic>
#include <memory>
#include <optional>
#include <vector>

#include "core/model/model.hpp"

namespace hysid::internal {

class HullNd {
 public:
  explicit HullNd(int n);  // n ≥ 3; neither copied nor moved (SampleSet holds it by pointer)
  ~HullNd();

  // x has n finite components (the caller checks). Returns true when the hull changed.
  bool Add(const ConstVecRef& x);
  int dimension() const;  // affine dimension of the hull, −1 when empty
  // n × h extreme points, in lexicographic order of their coordinates; nullopt once *stop is raised
  // (null: never; looked at every 4096 boundary facets and every 16 exact vertex tests).
  std::optional<Mat> Vertices(const std::atomic<bool>* stop) const;
  bool Contains(const ConstVecRef& x) const;           // exact: inside or on the boundary
  double SquaredDistance(const ConstVecRef& x) const;  // floating point; 0 inside; +inf when empty
  // n-dimensional; 0 below full dimension; nullopt once *stop is raised (every 4096 facets).
  std::optional<double> Volume(const std::atomic<bool>* stop) const;
  std::vector<Mat> Simplices() const;                  // a triangulation of the hull (see HullSimplices)

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Extreme points of the columns of `points` (n × N, n ≥ 3, all finite), lexicographic order, computed
// all at once: CGAL::extreme_points_3 for n = 3, a CGAL dD triangulation of all points for n ≥ 4.
Mat BatchExtremePoints(const Mat& points);

}  // namespace hysid::internal
