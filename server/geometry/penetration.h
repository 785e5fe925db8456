#pragma once

// Penetration depth of two convex hulls: the length of the shortest translation that
// separates them, computed exactly (to rounding) instead of by EPA.
//
// Theory: for the Minkowski difference D = B - A the signed distance is
//   s = max over unit n of h(n),   h(n) = min_B n.b - max_A n.a,
// (> 0: the gap; < 0: minus the penetration depth). When the hulls overlap the origin
// is inside D and the maximum is reached at a facet normal of D; every facet of D is a
// face of B, a face of A, or the sum of an edge of A and an edge of B whose arcs cross
// on the Gauss map (Gregorius 2013, "The separating axis test between convex
// polyhedra"). Evaluating h on all those candidates, with hill-climbing supports, gives
// the depth and its axis. Lower-dimensional hulls (a polygon, a segment, a point) have
// no usable Gauss map; their candidates are all edge pairs, in both orientations, and
// the normals of their planes.

#include "server/geometry/convex_hull.h"
#include "server/geometry/types.h"

namespace hapticd::geometry {

struct PenetrationResult {
  // -s: >= 0 when the hulls overlap (0 when they only touch); translating b by
  // depth * normal leaves them touching. Negative when they are disjoint, and then
  // -depth is only a lower bound on their distance (use GJK for distances).
  double depth = 0;
  // Unit, from a towards b: the axis of the shortest separating translation.
  Vector3 normal = Vector3::UnitX();
  // Witnesses: point_a on a (deepest inside b), point_b on b, with
  // point_a - point_b = depth * normal (to about 1e-10 of the hulls' size).
  Vector3 point_a = Vector3::Zero();
  Vector3 point_b = Vector3::Zero();
  // Candidate axes evaluated and edge pairs tested on the Gauss map (for benchmarks).
  int axes_evaluated = 0;
  int edge_pairs_tested = 0;
};

// Penetration depth of the hulls a and b, given in one frame. Precondition: both
// non-empty (dimension >= 0) and finite. Cost O(faces + E_a E_b) for two polyhedra,
// O(E_a E_b) support searches when either is lower-dimensional. Allocates (the
// contact features behind the witness points).
PenetrationResult CalcPenetration(const ConvexHull& a, const ConvexHull& b);

}  // namespace hapticd::geometry
