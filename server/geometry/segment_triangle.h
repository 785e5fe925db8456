#pragma once

// Segment-triangle and ray-triangle intersection (Möller & Trumbore 1997), in two
// flavours:
//  - the plain Möller-Trumbore test: fast, floating point; a segment aimed exactly
//    through an edge or vertex shared by two triangles can miss both.
//  - the watertight test: the hit/miss decision comes from exact orientation
//    predicates, so touching counts, and a segment through a shared edge or vertex of
//    a closed mesh hits at least one of the triangles around it. The proxies use it.
//
// Both report t (hit point = p + t (q - p), or origin + t dir for a ray) and the
// barycentric u, v of the hit (point = (1 - u - v) v0 + u v1 + v v2). Where the
// segment crosses the plane at several points (it lies in the plane) the result is a
// miss, by convention. Preconditions: finite input, a non-degenerate triangle
// (IsDegenerateTriangle() false), p != q, dir != 0. On degenerate input the answer is
// a miss or a hit with unspecified t, u, v; never a crash. The watertight test's t, u
// and v are always finite and in their ranges, even where rounding cannot resolve them
// (a segment within rounding of the plane hits where it enters the triangle).

#include "server/geometry/types.h"

namespace hapticd::geometry {

struct TriangleHit {
  bool hit = false;
  double t = 0;  // segment: in [0, 1]; ray: >= 0, in units of |dir|
  double u = 0;
  double v = 0;
};

// Möller-Trumbore in double precision; the bounds are inclusive.
TriangleHit IntersectSegmentTriangle(const Vector3& p, const Vector3& q, const Triangle& tri);
TriangleHit IntersectRayTriangle(const Vector3& origin, const Vector3& dir, const Triangle& tri);

// The watertight variant: exact hit decision, t/u/v computed in double. The segment
// test decides its five signs together in floating point with a proven error bound and
// asks the exact predicates only for the signs that bound leaves open (a segment
// within rounding of an edge, a vertex or the plane), so the answer is always that of
// the unfiltered test below.
TriangleHit IntersectSegmentTriangleWatertight(const Vector3& p, const Vector3& q,
                                               const Triangle& tri);
// The same test with every sign from the exact predicates (Orient3d): the oracle the
// filtered test is checked against.
TriangleHit IntersectSegmentTriangleWatertightUnfiltered(const Vector3& p, const Vector3& q,
                                                         const Triangle& tri);
TriangleHit IntersectRayTriangleWatertight(const Vector3& origin, const Vector3& dir,
                                           const Triangle& tri);

}  // namespace hapticd::geometry
