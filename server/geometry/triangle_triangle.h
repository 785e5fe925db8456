#pragma once

// Triangle-triangle overlap (Möller 1997, "A fast triangle-triangle intersection
// test"), with every comparison of Möller's interval test evaluated as an exact
// orientation predicate, as Guigue & Devillers 2003 ("Fast and robust
// triangle-triangle overlap test using orientation predicates") do. Triangles are
// closed sets: a shared vertex, a vertex on the other's face, edges that touch and
// coplanar triangles that share only a boundary point all intersect, exactly.
//
// Preconditions: finite coordinates, non-degenerate triangles (IsDegenerateTriangle()
// false for both). Non-finite input reports no intersection; degenerate triangles give
// an unspecified answer; neither crashes.

#include "server/geometry/types.h"

namespace hapticd::geometry {

struct TriangleIntersection {
  bool intersect = false;
  // Both triangles lie in one plane; then p0 and p1 are left at zero (the overlap is a
  // polygon, not a segment).
  bool coplanar = false;
  // When intersect && !coplanar: the intersection segment, endpoints in no particular
  // order. p0 == p1 exactly when the triangles touch at a single point. The decision
  // is exact; the endpoints are computed in double.
  Vector3 p0 = Vector3::Zero(), p1 = Vector3::Zero();
};

// True when the closed triangles share at least one point. Exact.
bool TrianglesIntersect(const Triangle& a, const Triangle& b);

// As TrianglesIntersect, plus the intersection segment for contact manifolds.
TriangleIntersection IntersectTriangles(const Triangle& a, const Triangle& b);

}  // namespace hapticd::geometry
