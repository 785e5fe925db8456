#include "server/geometry/sphere_triangle.h"

#include <cmath>

#include "server/geometry/exact_predicates.h"

namespace hapticd::geometry {
namespace {

// True when p, known to lie in the triangle's plane, lies in the closed triangle: the
// line through p along the (approximate) normal n crosses the plane only at p, and
// OrientLineEdge says exactly whether that line passes inside every edge.
bool CoplanarPointInTriangle(const Vector3& p, const Vector3& n, const Triangle& tri) {
  const int s0 = OrientLineEdge(p, n, tri.v0, tri.v1);
  const int s1 = OrientLineEdge(p, n, tri.v1, tri.v2);
  const int s2 = OrientLineEdge(p, n, tri.v2, tri.v0);
  return (s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0);
}

}  // namespace

SphereTriangleContact CalcSphereTriangleContact(const Sphere& sphere, const Triangle& tri) {
  SphereTriangleContact contact;
  const Vector3& c = sphere.center;
  // non-finite input: report no contact rather than signs of garbage
  if (!c.allFinite() || !std::isfinite(sphere.radius) || !tri.v0.allFinite() ||
      !tri.v1.allFinite() || !tri.v2.allFinite()) {
    return contact;
  }

  // the closest point carries the feature and the barycentrics
  const ClosestPointOnTriangle closest = FindClosestPointOnTriangle(c, tri);
  contact.point = closest.point;
  contact.u = closest.u;
  contact.v = closest.v;
  contact.feature = closest.feature;
  contact.distance = std::sqrt(closest.distance_squared);

  // the face normal; a degenerate triangle has none, so any unit vector will do
  Vector3 face_normal = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0);
  const double face_norm = face_normal.norm();
  face_normal = face_norm > 0 ? Vector3(face_normal / face_norm) : Vector3::UnitZ();

  // which side of the plane the centre is on, exactly
  const int side = Orient3d(tri.v0, tri.v1, tri.v2, c);
  if (side == 0 && face_norm > 0 && CoplanarPointInTriangle(c, face_normal, tri)) {
    // the centre lies on the triangle: no push direction; use the face normal
    contact.centre_on_triangle = true;
    contact.normal = face_normal;
    contact.point = c;
    contact.distance = 0;
  } else if (closest.feature == TriangleFeature::kFace && side != 0) {
    // over the face: straight out of the plane, on the centre's side
    contact.normal = side > 0 ? face_normal : Vector3(-face_normal);
  } else {
    // nearest an edge or a vertex: from there towards the centre
    const Vector3 offset = c - closest.point;
    const double length = offset.norm();
    if (length > 0 && std::isfinite(length)) {
      contact.normal = offset / length;
    } else {
      // the offset was lost to rounding: fall back on the face normal, centre's side
      contact.normal = side < 0 ? Vector3(-face_normal) : face_normal;
    }
  }
  contact.depth = sphere.radius - contact.distance;
  contact.touching = contact.depth >= 0;
  return contact;
}

}  // namespace hapticd::geometry
