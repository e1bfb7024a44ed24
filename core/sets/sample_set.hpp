// Λ (flow samples) and Γ (jump samples) with their convex hulls Ĉ = conv Λ, D̂ = conv Γ
// (Algorithm 2), updated incrementally: a sample inside the current hull costs a membership test;
// one outside updates the hull locally. Never recomputed from all points.
//
// Every state dimension n ≥ 1 is supported (n < 1 throws std::invalid_argument at construction):
// 1-D an interval, 2-D an angular ring, n ≥ 3 a boundary star (below); all exact.
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
//
// n ≥ 3 (core/sets/hull_nd.cpp): every decision is an exact CGAL orientation (or affine-hull) predicate —
// the 3-D kernel's for n = 3, Epick_d's for n ≥ 4 (static dimension for n = 4). Two representations:
//   early   the samples that arrived outside the hull, in a CGAL dD triangulation (CGAL::Triangulation),
//           which holds degenerate hulls exactly: hull_dimension() is its current dimension (−1 empty,
//           0 a point, 1 collinear samples, 2 coplanar ones, ...). Membership is one locate (a walk
//           from the previous sample's cell). Used until the hull is n-dimensional and the rounded
//           centroid of one of its cells is strictly inside that cell — normally from the (n+1)-th
//           affinely independent sample on; for samples in a lower-dimensional flat, forever.
//   star    then the hull's boundary facets ((n−1)-simplices with their neighbours) seen from that
//           interior point c: the cones (c, F) triangulate the hull, as the wedges do in 2-D. Only the
//           current boundary is stored (a dD triangulation keeps every cell it ever built: for samples
//           along a smooth curve, which are in convex position, that grows quadratically).
// Cost of Add in the star:
//   inside   a visibility walk over the cones, started at the previous sample's facet (consecutive
//            samples: a few steps of at most n orientation tests each), then one orientation test
//            against the facet reached;
//   outside  the same, plus the removal of the facets the sample sees and one new facet per ridge of
//            their boundary: O(n · facets seen). Samples along a curve each see O(h) facets (a
//            4000-sample 3-D spiral with 2123 extreme points takes 0.2 s in the tests, a Contains before
//            each Add included). The walk falls back to a scan of all facets if it has not ended
//            after 16 steps per facet (never seen in the tests).
// The boundary of an n-D hull can have Θ(h^⌊n/2⌋) facets, and trajectory data comes close from n = 4
// on: 2000 samples along a smooth 4-D curve, all extreme, make 267087 facets (6.6 s); 40001 samples of
// the same kind of curve (17638 extreme) take 111 s. Measured inside samples (a second pass over the
// same trajectory): 0.3 µs in 3-D, 2 µs in that 4-D case.
// Coplanar boundary facets are not merged, so a boundary vertex may lie inside a hull face or edge;
// vertices() returns the extreme points only, exactly: a vertex on no ridge between two coplanar
// facets is extreme; any other is tested exactly against the hull of its boundary neighbours (a small
// dD triangulation). Cost O(boundary) plus one such test per vertex on a flat ridge. The result is
// the set BatchHullVertices gives (tests: random, integer-grid and cospherical clouds in 3-D to 5-D,
// a cube with points on its edges and faces, coplanar and collinear samples), in lexicographic order
// (x1, then x2, ...). Contains(x, tolerance > 0) measures the distance in floating point to the
// nearest boundary facet (n-dimensional hull) or cell (lower-dimensional). Volume() sums the cones
// (floating point); 0 below full dimension. Unlike 2-D, the const members of an n ≥ 3 set must not be
// called from several threads at once: CGAL's locate in the early representation advances the
// triangulation's random generator.
#pragma once

#include <atomic>
#include <memory>
#include <optional>
#include <vector>

#include "core/model/model.hpp"

namespace hysid {

class SampleSet {
 public:
  // Throws std::invalid_argument when dimension < 1.
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
  long size() const;           // finite samples added (inside the hull or not)
  long non_finite() const;     // samples ignored because a component was NaN or ±inf
  int hull_dimension() const;  // affine dimension of the hull: -1 empty, 0 point, 1 segment, 2 polygon, ... n
  Mat vertices() const;        // n × h extreme points (2-D: counter-clockwise; n ≥ 3: lexicographic)
  // Inside or on the hull, or within Euclidean distance `tolerance` of it (also for a degenerate
  // hull: a point, a segment, a polygon in 3-D, ...). With tolerance 0 the test is exact. False for
  // an empty hull or a non-finite x. Throws std::invalid_argument when x.size() != dimension().
  bool Contains(ConstVecRef x, double tolerance = 0.0) const;
  long version() const;  // incremented whenever the hull changes (0 while empty)
  // n-dimensional volume: length in 1-D, area in 2-D, volume for n ≥ 3; 0 when the hull has a lower
  // affine dimension than n.
  double Volume() const;
  // vertices() and Volume() that look at *stop (null: never) while they work and give nullopt once it
  // is raised — for n ≥ 3, whose boundary can have many facets: every 4096 boundary facets and every 16
  // exact vertex tests, first before any (CGAL's own walk over a triangulation's boundary cells in the
  // early representation is not interrupted). 1-D and 2-D: O(h), not interrupted, never nullopt.
  std::optional<Mat> vertices(const std::atomic<bool>* stop) const;
  std::optional<double> Volume(const std::atomic<bool>* stop) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The extreme points of the finite columns of `points` (n × N) all at once, for checking the
// incremental hull: 1-D min and max; 2-D CGAL::convex_hull_2, counter-clockwise from the
// lexicographically smallest; 3-D CGAL::extreme_points_3 (quickhull) and n ≥ 4 a CGAL dD
// triangulation of all points filtered as vertices() filters, both in lexicographic order. Throws
// std::invalid_argument for n < 1.
Mat BatchHullVertices(const Mat& points);

// A triangulation of the convex hull of the finite columns of `points` (n × N, n ≥ 3): simplices of
// the hull's affine dimension d, each n × (d + 1), that cover the hull and overlap only on their
// boundaries (empty for no point, one n × 1 for a single point). Built by the incremental hull of
// SampleSet: once the hull is n-dimensional, the cones from an interior point over its boundary
// facets; before that, the cells of a dD triangulation. For quadratures over Ĉ (set_metrics.cpp).
// Throws std::invalid_argument for n < 3.
std::vector<Mat> HullSimplices(const Mat& points);

}  // namespace hysid
