// Λ (flow samples) and Γ (jump samples) with their convex hulls Ĉ = conv Λ, D̂ = conv Γ
// (Algorithm 2), updated incrementally: a sample inside the current hull costs a membership test;
// one outside updates the hull locally. Never recomputed from all points.
//
// 2-D: an angularly ordered hull with CGAL's exact orientation predicate (amortised O(log h) per
// insertion). Other dimensions: see sample_set.cpp. Degenerate hulls (a single point, collinear
// samples such as the jump samples of impact-msd on the half-line ξ1 = 0) are represented exactly:
// hull_dimension() says which.
#pragma once

#include <memory>

#include "core/model.hpp"

namespace hysid {

class SampleSet {
 public:
  explicit SampleSet(int dimension);
  ~SampleSet();
  SampleSet(SampleSet&&) noexcept;
  SampleSet& operator=(SampleSet&&) noexcept;
  SampleSet(const SampleSet&) = delete;
  SampleSet& operator=(const SampleSet&) = delete;

  // Adds a sample (non-finite samples are ignored and counted).
  void Add(ConstVecRef x);
  int dimension() const;
  long size() const;            // samples added
  int hull_dimension() const;   // affine dimension of the hull: -1 empty, 0 point, 1 segment, 2 …
  Mat vertices() const;         // n × h hull vertices (2-D: counter-clockwise)
  // Inside or on the hull, within `tolerance` (Euclidean distance).
  bool Contains(ConstVecRef x, double tolerance = 0.0) const;
  long version() const;         // incremented whenever the hull changes
  double Volume() const;        // area in 2-D; 0 for a degenerate hull

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The convex hull of all points at once (CGAL), n × h, for checking the incremental one.
Mat BatchHullVertices(const Mat& points);

}  // namespace hysid
