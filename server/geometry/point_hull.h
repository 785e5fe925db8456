#pragma once

// The signed distance from a point to a convex polyhedron, with the nearest boundary
// point and the outward normal there: what a point (or a sphere's centre) asks of a
// hull. Outside, GJK's nearest point; inside (or on the boundary), the projection onto
// the face plane the point is least deep behind.

#include "server/geometry/convex_hull.h"
#include "server/geometry/types.h"

namespace hapticd::geometry {

struct PointHullResult {
  bool found = false;          // false: see CalcPointHullDistance
  double signed_distance = 0;  // > 0 outside, <= 0 inside (0 on the boundary)
  Vector3 point = Vector3::Zero();    // the nearest boundary point
  Vector3 normal = Vector3::UnitZ();  // unit, outward there (towards p when outside)
};

// For a hull of dimension 3 (BuildConvexHull). A point outside by a gap too small to
// have a direction (subnormal) is answered as on the boundary, by the faces. Not found
// (found false, the other fields at their defaults): a NaN or infinite p, a hull of
// lower dimension, or one whose every face normal underflowed (no direction to push
// along); also a point inside when the thread's work meter (work_meter.h) cannot pay
// for the faces, a unit per eight (GJK's searches are charged as CalcGjkDistance
// says). Allocation-free.
PointHullResult CalcPointHullDistance(const ConvexHull& hull, const Vector3& p);

}  // namespace hapticd::geometry
