// How well the identified sets Ĉ = conv Λ and D̂ = conv Γ (core/sets/sample_set.hpp) approximate the
// model's true flow set C and jump set D.
//
//   jump_hausdorff      the one-sided Hausdorff distance from D̂ to D: max over ξ ∈ D̂ of dist(ξ, D),
//                       with the model's DistanceToJumpSet. It is taken over the vertices of D̂:
//                       when D is convex, dist(·, D) is a convex function and its maximum over the
//                       polytope D̂ is attained at a vertex, so the value is exact (all built-in
//                       models: D = {ξ1 = 0, ξ2 ≤ 0}, a half-line). For a non-convex D it is a lower
//                       bound. NaN when D̂ is empty or the model has no DistanceToJumpSet.
//   flow_outside_share  |Ĉ \ C| / |Ĉ|, the share of Ĉ's area (2-D) or length (a segment, or 1-D)
//                       outside C, by a deterministic quadrature with the model's InFlowSet: the
//                       triangle fan of Ĉ from its first vertex, each triangle cut into m² congruent
//                       sub-triangles (m ∝ √area, about 2^16 in all) tested at their centroids; a
//                       segment by the midpoint rule on 2^16 cells. A point hull gives 0 or 1. The
//                       error is of the order of the share of cells cut by C's boundary
//                       (≈ 1/m per unit of boundary inside Ĉ). NaN when Ĉ is empty.
//                       n ≥ 3: the share of Ĉ's d-dimensional volume (d = its affine dimension:
//                       a polyhedron, or a polygon, segment or point in 3-D, ...). Ĉ is triangulated
//                       from its vertices (HullSimplices in core/sets/sample_set.hpp: cones from an interior
//                       point over the boundary facets, or a dD triangulation's cells for a lower-
//                       dimensional hull); each d-simplex is cut into m^d sub-simplices of equal volume
//                       (the Kuhn/Freudenthal subdivision; m^d ∝ its volume, about 2^16 cells in all)
//                       tested at their centroids — for d = 2 the sub-triangles above, for d = 1 the
//                       midpoint rule. The error is at most the volume share of the cells cut by C's
//                       boundary (≈ 1/m per unit of boundary); on a unit cube cut by planes the tests
//                       see 3e-5 to 1e-3. Cost: the triangulation of Ĉ's vertices plus about 2^16
//                       InFlowSet calls (at least one per simplex).
#pragma once

#include <limits>

#include "core/model/model.hpp"
#include "core/sets/sample_set.hpp"

namespace hysid {

struct SetMetrics {
  double jump_hausdorff = std::numeric_limits<double>::quiet_NaN();
  double flow_outside_share = std::numeric_limits<double>::quiet_NaN();
};

SetMetrics CompareSets(const Model& model, const SampleSet& flow_set, const SampleSet& jump_set);

// The same from hull vertices as SampleSet::vertices() gives them (n × h, 2-D polygons in
// counter-clockwise order; for n ≥ 3 any order), e.g. IdentifyResult::flow_hull and jump_hull.
// Throws std::invalid_argument when the row count is not the model's state size.
SetMetrics CompareSets(const Model& model, const Mat& flow_hull, const Mat& jump_hull);

}  // namespace hysid
