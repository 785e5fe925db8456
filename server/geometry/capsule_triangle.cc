#include "server/geometry/capsule_triangle.h"

#include <algorithm>
#include <cmath>

#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/exact_predicates.h"
#include "server/geometry/segment_segment.h"
#include "server/geometry/segment_triangle.h"

namespace hapticd::geometry {
namespace {

bool IsFinite(const Capsule& c, const Triangle& t) {
  return c.p0.allFinite() && c.p1.allFinite() && std::isfinite(c.radius) &&
         t.v0.allFinite() && t.v1.allFinite() && t.v2.allFinite();
}

// For points of the triangle's plane, OrientLineEdge along the (approximate) normal n
// is the exact 2D orientation of (a, b, p) in that plane.
int CoplanarOrient(const Vector3& a, const Vector3& b, const Vector3& p, const Vector3& n) {
  return OrientLineEdge(p, n, a, b);
}

// True when p, a point of the triangle's plane, lies in the closed triangle.
bool CoplanarPointInTriangle(const Vector3& p, const Vector3& n, const Triangle& tri) {
  const int s0 = CoplanarOrient(tri.v0, tri.v1, p, n);
  const int s1 = CoplanarOrient(tri.v1, tri.v2, p, n);
  const int s2 = CoplanarOrient(tri.v2, tri.v0, p, n);
  return (s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0);
}

// True when segment p0-p1, lying in the triangle's plane, meets the closed triangle:
// an endpoint inside, or the segment meets an edge (closed segments; a collinear
// overlap with an edge always shows up as an endpoint inside or a crossing of the
// neighbouring edge, so the all-collinear case needs no test of its own).
bool CoplanarSegmentMeetsTriangle(const Vector3& p0, const Vector3& p1, const Vector3& n,
                                  const Triangle& tri) {
  if (CoplanarPointInTriangle(p0, n, tri) || CoplanarPointInTriangle(p1, n, tri)) return true;
  const Vector3* corners[] = {&tri.v0, &tri.v1, &tri.v2};
  for (int i = 0; i < 3; ++i) {
    const Vector3& a = *corners[i];
    const Vector3& b = *corners[(i + 1) % 3];
    const int o1 = CoplanarOrient(a, b, p0, n);
    const int o2 = CoplanarOrient(a, b, p1, n);
    if (o1 * o2 > 0 || (o1 == 0 && o2 == 0)) continue;
    const int o3 = CoplanarOrient(p0, p1, a, n);
    const int o4 = CoplanarOrient(p0, p1, b, n);
    if (o3 * o4 <= 0) return true;
  }
  return false;
}

// A candidate for the shortest translation that frees a crossing axis.
struct Escape {
  double amount = 0;
  Vector3 direction = Vector3::UnitZ();
  Vector3 point_on_axis = Vector3::Zero();
  Vector3 point_on_triangle = Vector3::Zero();
  double s = 0;
};

// The axis crosses the triangle: its penetration depth, the shortest translation
// that frees it. Derivation: the axis and the triangle overlap iff the origin lies in
// their Minkowski difference M = {p - x}, a prism whose facets are the two caps
// p0 - T and p1 - T (normals ±n) and one side per edge (normal ± d x e). The origin
// is inside M, so its distance to M's boundary is its smallest distance to a facet
// plane, and the nearest point of that plane lies on the facet. Caps: the endpoint's
// height over the plane (move it back onto the plane). Sides: the distance between
// the axis line and the edge line (slide the axis off over the edge).
Escape FindAxisEscape(const Vector3& p0, const Vector3& p1, const Triangle& tri,
                      const Vector3& n) {
  const Vector3 d = p1 - p0;
  const double h0 = n.dot(p0 - tri.v0);
  const double h1 = n.dot(p1 - tri.v0);
  Escape best;
  // cap below: lift the lower endpoint up onto the plane
  const bool p0_lower = h0 <= h1;
  const double h_low = p0_lower ? h0 : h1;
  const Vector3& low = p0_lower ? p0 : p1;
  best = {std::max(0.0, -h_low), n, low, low - h_low * n, p0_lower ? 0.0 : 1.0};
  // cap above: push the upper endpoint down onto the plane
  const double h_high = p0_lower ? h1 : h0;
  const Vector3& high = p0_lower ? p1 : p0;
  if (std::max(0.0, h_high) < best.amount) {
    best = {std::max(0.0, h_high), -n, high, high - h_high * n, p0_lower ? 1.0 : 0.0};
  }
  // sides: slide the axis out over an edge, perpendicular to the axis and the edge
  const Vector3* corners[] = {&tri.v0, &tri.v1, &tri.v2};
  for (int i = 0; i < 3; ++i) {
    const Vector3& a = *corners[i];
    const Vector3& b = *corners[(i + 1) % 3];
    const Vector3& opposite = *corners[(i + 2) % 3];
    Vector3 m = d.cross(b - a);
    const double length = m.norm();
    // the axis parallel to the edge: no such facet
    if (!(length > 0)) continue;
    m /= length;
    // point it out of the triangle, across the edge
    if (m.dot(opposite - a) > 0) m = -m;
    const double amount = std::max(0.0, m.dot(a - p0));
    if (amount < best.amount) {
      const SegmentSegmentClosest c = FindClosestPointsBetweenSegments(p0, p1, a, b);
      best = {amount, m, c.point_a, c.point_b, c.s};
    }
  }
  return best;
}

// The closest points of a non-crossing axis and the triangle: the nearer of the two
// endpoints' closest points and the three segment-edge closest pairs.
struct Closest {
  double distance_squared = 0;
  Vector3 point_on_axis = Vector3::Zero();
  Vector3 point_on_triangle = Vector3::Zero();
  double s = 0;
  bool over_face = false;  // an endpoint over the face interior
};

Closest FindClosestAxisPoints(const Vector3& p0, const Vector3& p1, const Triangle& tri) {
  Closest best;
  // the endpoints against the triangle
  const ClosestPointOnTriangle c0 = FindClosestPointOnTriangle(p0, tri);
  best = {c0.distance_squared, p0, c0.point, 0.0, c0.feature == TriangleFeature::kFace};
  const ClosestPointOnTriangle c1 = FindClosestPointOnTriangle(p1, tri);
  if (c1.distance_squared < best.distance_squared) {
    best = {c1.distance_squared, p1, c1.point, 1.0, c1.feature == TriangleFeature::kFace};
  }
  // the axis against each edge
  const Vector3* corners[] = {&tri.v0, &tri.v1, &tri.v2};
  for (int i = 0; i < 3; ++i) {
    const SegmentSegmentClosest c =
        FindClosestPointsBetweenSegments(p0, p1, *corners[i], *corners[(i + 1) % 3]);
    if (c.distance_squared < best.distance_squared) {
      best = {c.distance_squared, c.point_a, c.point_b, c.s, false};
    }
  }
  return best;
}

}  // namespace

CapsuleTriangleContact CalcCapsuleTriangleContact(const Capsule& capsule,
                                                  const Triangle& tri) {
  CapsuleTriangleContact contact;
  // non-finite input: report no contact rather than signs of garbage
  if (!IsFinite(capsule, tri)) return contact;
  const Vector3& p0 = capsule.p0;
  const Vector3& p1 = capsule.p1;

  // the unit face normal; a degenerate triangle has none, so any unit vector will do
  Vector3 n = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0);
  const double n_norm = n.norm();
  n = n_norm > 0 ? Vector3(n / n_norm) : Vector3::UnitZ();

  // the endpoints' sides of the plane, exactly
  const int side0 = Orient3d(tri.v0, tri.v1, tri.v2, p0);
  const int side1 = Orient3d(tri.v0, tri.v1, tri.v2, p1);
  bool in_plane_overlap = false;
  if (side0 == 0 && side1 == 0) {
    // the axis lies in the plane (or is a point of it)
    in_plane_overlap = n_norm > 0 && CoplanarSegmentMeetsTriangle(p0, p1, n, tri);
  } else if (side0 * side1 <= 0) {
    // the axis reaches the plane: does it cross (or touch) the triangle there?
    if (IntersectSegmentTriangleWatertight(p0, p1, tri).hit) {
      const Escape escape = FindAxisEscape(p0, p1, tri, n);
      contact.axis_crosses = true;
      contact.distance = 0;
      contact.depth = capsule.radius + escape.amount;
      contact.normal = escape.direction;
      contact.point_on_axis = escape.point_on_axis;
      contact.point_on_triangle = escape.point_on_triangle;
      contact.s = escape.s;
      contact.touching = contact.depth >= 0;
      return contact;
    }
  }

  // no crossing: the closest points
  const Closest closest = FindClosestAxisPoints(p0, p1, tri);
  contact.point_on_axis = closest.point_on_axis;
  contact.point_on_triangle = closest.point_on_triangle;
  contact.s = closest.s;
  contact.distance = std::sqrt(closest.distance_squared);
  const int side = closest.s == 0 ? side0 : (closest.s == 1 ? side1 : 0);
  if (in_plane_overlap) {
    // the axis lies in the plane and meets the triangle: no push direction
    contact.axis_in_plane = true;
    contact.distance = 0;
    contact.normal = n;
  } else if (closest.over_face && side != 0) {
    // an endpoint over the face: straight out of the plane, on its side
    contact.normal = side > 0 ? n : Vector3(-n);
  } else {
    // from the triangle towards the axis
    const Vector3 offset = closest.point_on_axis - closest.point_on_triangle;
    const double length = offset.norm();
    if (length > 0 && std::isfinite(length)) {
      contact.normal = offset / length;
    } else {
      // the offset was lost to rounding: the face normal, on the axis' side
      contact.normal = (side0 < 0 || side1 < 0) ? Vector3(-n) : n;
    }
  }
  contact.depth = capsule.radius - contact.distance;
  contact.touching = contact.depth >= 0;
  return contact;
}

}  // namespace hapticd::geometry
