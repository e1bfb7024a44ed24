// Λ (flow samples) and Γ (jump samples) with their convex hulls Ĉ = conv Λ, D̂ = conv Γ
// (Algorithm 2), updated incrementally: a sample inside the current hull costs a membership test;
// one outside updates the hull locally. Never recomputed from all points.
//
// Supported state dimensions: 1 and 2. Any other dimension throws std::invalid_argument at
// construction (an exact incremental hull in n ≥ 3 dimensions is not implemented; the identifier
// then needs IdentifierSettings::sets = false).
//
// 2-D: the hull vertices are kept in angular order around a fixed reference point c strictly inside
// the hull (a balanced search tree keyed by angle). Every decision uses CGAL's exact orientation
// predicate (Exact_predicates_inexact_constructions_kernel) and exact coordinate comparisons, so the
// vertex set is exactly that of the batch hull of the same points (BatchHullVertices). Cost of Add:
//   inside the hull   the membership test only: the angular wedge of the sample (first tried next to
//                     the previous sample's wedge, a few orientation tests; else a binary search,
//                     O(log h)) and one orientation test against the wedge's edge;
//   outside           the same, plus an O(log h) insertion and the removal of the vertices the new
//                     one makes reflex (each vertex is removed once: amortised O(log h)).
// Degenerate hulls are represented exactly: no sample (hull_dimension −1), one distinct point (0),
// collinear samples as a segment (1; e.g. jump samples exactly on the wall of impact-msd), promoted to a
// polygon when the first non-collinear sample arrives. Vertices are extreme points only (no point in
// the relative interior of an edge), counter-clockwise, starting at the lexicographically smallest
// (x1, then x2) — the order of CGAL::convex_hull_2. Should the first triangle be so thin that its
// rounded centroid is not strictly inside it, the hull is kept as a plain vertex list (O(h) per
// sample, recomputed with CGAL::convex_hull_2 on change) until a reference point is found.
//
// 1-D: the interval [min, max]; hull_dimension 0 or 1; Volume() is its length.
#pragma once

#include <memory>

#include "core/model.hpp"

namespace hysid {

class SampleSet {
 public:
  // Throws std::invalid_argument unless dimension is 1 or 2.
  explicit SampleSet(int dimension);
  ~SampleSet();
  SampleSet(SampleSet&&) noexcept;
  SampleSet& operator=(SampleSet&&) noexcept;
  SampleSet(const SampleSet&) = delete;
  SampleSet& operator=(const SampleSet&) = delete;

  // Adds a sample. Non-finite samples are ignored and counted (non_finite()). Throws
  // std::invalid_argument when x.size() != dimension().
  void Add(const ConstVecRef& x);
  int dimension() const;
  long size() const;            // finite samples added (inside the hull or not)
  long non_finite() const;      // samples ignored because a component was NaN or ±inf
  int hull_dimension() const;   // affine dimension of the hull: -1 empty, 0 point, 1 segment, 2 polygon
  Mat vertices() const;         // n × h hull vertices (2-D: counter-clockwise, see above)
  // Inside or on the hull, or within Euclidean distance `tolerance` of it (also for a point or a
  // segment hull). With tolerance 0 the test is exact. False for an empty hull or a non-finite x.
  bool Contains(ConstVecRef x, double tolerance = 0.0) const;
  long version() const;         // incremented whenever the hull changes (0 while empty)
  double Volume() const;        // area in 2-D (0 for a point or segment); length in 1-D

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The convex hull of the finite columns of `points` (n × N, n = 1 or 2) all at once, with
// CGAL::convex_hull_2 in 2-D: n × h extreme points, counter-clockwise from the lexicographically
// smallest. For checking the incremental hull. Throws std::invalid_argument for other n.
Mat BatchHullVertices(const Mat& points);

}  // namespace hysid
