#include "server/geometry/triangle_triangle.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "server/geometry/exact_predicates.h"

namespace hapticd::geometry {
namespace {

// Theory of operation (Möller 1997, decided as in Guigue & Devillers 2003).
//
// If the triangles are not coplanar and neither lies strictly on one side of the
// other's plane, the two planes meet in a line L, each triangle meets L in a closed
// interval, and the triangles intersect iff the intervals overlap.
//
// Canonical form: rotate each triangle (keeping its orientation) so that its first
// vertex, the apex, lies alone on one closed side of the other plane; then flip the
// other triangle (swap its last two vertices) so that the apex is on that plane's
// non-negative side. After this, with [a, b, c, d] = Orient3d(a, b, c, d):
//   [p2, q2, r2, p1] >= 0 >= [p2, q2, r2, q1], [p2, q2, r2, r1]   (not all zero)
//   [p1, q1, r1, p2] >= 0 >= [p1, q1, r1, q2], [p1, q1, r1, r2]
// Triangle 1 meets L in [j1, i1], where i1 = edge p1q1 ∩ plane 2 and
// j1 = edge p1r1 ∩ plane 2, ordered along D = N1 x N2; triangle 2 meets it in
// [i2, j2], i2 = p2q2 ∩ plane 1, j2 = p2r2 ∩ plane 1.
//
// For X = edge p1x1 ∩ plane 2 and Y = edge p2y2 ∩ plane 1, with u = x1 - p1 and
// w = y2 - p2:  [p1, x1, p2, y2] = det(u, p2 - p1, w) = det(u, Y - X, w), since
// p2 - p1 differs from Y - X by multiples of u and w. Y - X = λ D, and
// det(u, D, w) = (N1·w)(N2·u) - (N2·w)(N1·u) = (N1·w)(N2·u) > 0 (u lies in plane 1,
// and both edges go strictly from the apex side to the other side). So
//   sign(Y - X along D) = sign [p1, x1, p2, y2],
// exactly, even when an endpoint lies on the plane. The intervals overlap iff
//   j1 <= j2  ⟺  [p1, r1, p2, r2] >= 0   and   i2 <= i1  ⟺  [p1, q1, p2, q2] <= 0,
// and the intersection segment is [max(j1, i2), min(i1, j2)].

// Orientation signs of three points against a triangle's plane.
using Signs = std::array<int, 3>;

Signs SignsAgainstPlane(const Triangle& plane, const Triangle& t) {
  return {Orient3d(plane.v0, plane.v1, plane.v2, t.v0),
          Orient3d(plane.v0, plane.v1, plane.v2, t.v1),
          Orient3d(plane.v0, plane.v1, plane.v2, t.v2)};
}

// True when all three points lie strictly on one side of the plane.
bool StrictlyOneSide(const Signs& s) {
  return (s[0] > 0 && s[1] > 0 && s[2] > 0) || (s[0] < 0 && s[1] < 0 && s[2] < 0);
}

bool AllZero(const Signs& s) { return s[0] == 0 && s[1] == 0 && s[2] == 0; }

bool IsFinite(const Triangle& t) {
  return t.v0.allFinite() && t.v1.allFinite() && t.v2.allFinite();
}

const Vector3& Vertex(const Triangle& t, int i) {
  return i == 0 ? t.v0 : (i == 1 ? t.v1 : t.v2);
}

// The vertex alone on its closed side of the other plane, and that side (+1 or -1).
struct Apex {
  int index = 0;
  int side = 1;
};

// Precondition: the signs are neither all zero nor all equal and nonzero.
Apex FindApex(const Signs& s) {
  for (int k = 0; k < 3; ++k) {
    const int o1 = s[(k + 1) % 3];
    const int o2 = s[(k + 2) % 3];
    if (s[k] > 0 && o1 <= 0 && o2 <= 0) return {k, 1};
    if (s[k] < 0 && o1 >= 0 && o2 >= 0) return {k, -1};
  }
  // only (0, +, +) up to rotation and sign is left: the triangle touches the plane at
  // one vertex, which becomes the apex on the side opposite to the other two
  for (int k = 0; k < 3; ++k) {
    if (s[k] == 0) return {k, -s[(k + 1) % 3]};
  }
  return {};
}

// One triangle in canonical form: vertices rotated to start at the apex, and which
// of them lie exactly on the other plane.
struct Canonical {
  Vector3 p, q, r;
  bool p_on = false, q_on = false, r_on = false;
};

Canonical MakeCanonical(const Triangle& t, const Signs& s, const Apex& apex) {
  const int k = apex.index, k1 = (k + 1) % 3, k2 = (k + 2) % 3;
  return {Vertex(t, k), Vertex(t, k1), Vertex(t, k2), s[k] == 0, s[k1] == 0, s[k2] == 0};
}

// Flips a triangle's orientation, keeping its apex first.
void Flip(Canonical& c) {
  std::swap(c.q, c.r);
  std::swap(c.q_on, c.r_on);
}

// Where the edge apex -> x crosses the plane through o with normal n (any length).
// Exact when an endpoint lies on the plane; otherwise interpolated in double and
// clamped to the edge, so a near-parallel edge cannot throw the point off it.
Vector3 CrossPlane(const Vector3& apex, bool apex_on, const Vector3& x, bool x_on,
                   const Vector3& o, const Vector3& n) {
  if (x_on) return x;
  if (apex_on) return apex;
  const double d_apex = n.dot(apex - o);
  const double d_x = n.dot(x - o);
  double t = d_apex / (d_apex - d_x);
  // the exact signs say the edge crosses; rounding (or 0/0) must not say otherwise
  if (!(t >= 0)) t = 0;
  if (t > 1) t = 1;
  return apex + t * (x - apex);
}

// Projects a point of the common plane onto the coordinate plane that drops `axis`.
Vector2 Drop(const Vector3& p, int axis) {
  return axis == 0 ? Vector2(p.y(), p.z()) : (axis == 1 ? Vector2(p.z(), p.x())
                                                        : Vector2(p.x(), p.y()));
}

// True when all of b lies strictly outside the directed edge e0 -> e1 of a
// counter-clockwise triangle.
bool SeparatedByEdge(const Vector2& e0, const Vector2& e1, const std::array<Vector2, 3>& b) {
  return Orient2d(e0, e1, b[0]) < 0 && Orient2d(e0, e1, b[1]) < 0 &&
         Orient2d(e0, e1, b[2]) < 0;
}

// Coplanar closed triangles overlap iff no edge line of either separates them
// strictly (the separating axis theorem in 2D: a separating direction can always be
// taken normal to an edge of the Minkowski difference, i.e. to an edge of a or b).
// Dropping a coordinate is exact, so the 2D predicates decide the 3D question.
bool CoplanarTrianglesOverlap(const Triangle& a, const Triangle& b) {
  // drop the axis along which the plane's normal is largest; if rounding picked an
  // axis the plane contains, the projection is degenerate: try the others
  const Vector3 n = (a.v1 - a.v0).cross(a.v2 - a.v0).cwiseAbs();
  int axis = n.x() >= n.y() ? (n.x() >= n.z() ? 0 : 2) : (n.y() >= n.z() ? 1 : 2);
  std::array<Vector2, 3> pa, pb;
  int orientation_a = 0;
  for (int attempt = 0; attempt < 3 && orientation_a == 0; ++attempt) {
    if (attempt > 0) axis = (axis + 1) % 3;
    pa = {Drop(a.v0, axis), Drop(a.v1, axis), Drop(a.v2, axis)};
    orientation_a = Orient2d(pa[0], pa[1], pa[2]);
  }
  pb = {Drop(b.v0, axis), Drop(b.v1, axis), Drop(b.v2, axis)};
  const int orientation_b = Orient2d(pb[0], pb[1], pb[2]);
  // degenerate input (outside the preconditions): no answer to give
  if (orientation_a == 0 || orientation_b == 0) return false;
  // make both counter-clockwise in the projection
  if (orientation_a < 0) std::swap(pa[1], pa[2]);
  if (orientation_b < 0) std::swap(pb[1], pb[2]);
  for (int i = 0; i < 3; ++i) {
    if (SeparatedByEdge(pa[i], pa[(i + 1) % 3], pb)) return false;
    if (SeparatedByEdge(pb[i], pb[(i + 1) % 3], pa)) return false;
  }
  return true;
}

// The shared kernel; computes the segment only when asked.
TriangleIntersection Intersect(const Triangle& a, const Triangle& b, bool want_segment) {
  TriangleIntersection result;
  // non-finite input: no intersection, rather than signs of garbage
  if (!IsFinite(a) || !IsFinite(b)) return result;

  // reject when either triangle lies strictly on one side of the other's plane
  const Signs sa = SignsAgainstPlane(b, a);
  if (StrictlyOneSide(sa)) return result;
  const Signs sb = SignsAgainstPlane(a, b);
  if (StrictlyOneSide(sb)) return result;

  // coplanar: a lies in b's plane, so the planes coincide
  if (AllZero(sa) || AllZero(sb)) {
    result.coplanar = true;
    result.intersect = CoplanarTrianglesOverlap(a, b);
    return result;
  }

  // canonical form (see the theory of operation above)
  const Apex apex_a = FindApex(sa);
  const Apex apex_b = FindApex(sb);
  Canonical c1 = MakeCanonical(a, sa, apex_a);
  Canonical c2 = MakeCanonical(b, sb, apex_b);
  if (apex_a.side < 0) Flip(c2);
  if (apex_b.side < 0) Flip(c1);

  // the interval test: j1 <= j2 and i2 <= i1
  const int i_order = Orient3d(c1.p, c1.q, c2.p, c2.q);
  if (i_order > 0) return result;
  const int j_order = Orient3d(c1.p, c1.r, c2.p, c2.r);
  if (j_order < 0) return result;
  result.intersect = true;
  if (!want_segment) return result;

  // the segment [max(j1, i2), min(i1, j2)]; the planes' normals for interpolation
  const Vector3 n1 = (a.v1 - a.v0).cross(a.v2 - a.v0);
  const Vector3 n2 = (b.v1 - b.v0).cross(b.v2 - b.v0);
  const Vector3 i1 = CrossPlane(c1.p, c1.p_on, c1.q, c1.q_on, b.v0, n2);
  const Vector3 j1 = CrossPlane(c1.p, c1.p_on, c1.r, c1.r_on, b.v0, n2);
  const Vector3 i2 = CrossPlane(c2.p, c2.p_on, c2.q, c2.q_on, a.v0, n1);
  const Vector3 j2 = CrossPlane(c2.p, c2.p_on, c2.r, c2.r_on, a.v0, n1);

  // a single touching point: report one point twice, a vertex where there is one
  if (c1.p_on || c2.p_on || i_order == 0 || j_order == 0) {
    Vector3 point;
    if (c1.p_on) {
      point = c1.p;
    } else if (c2.p_on) {
      point = c2.p;
    } else if (i_order == 0) {
      point = c2.q_on && !c1.q_on ? i2 : i1;
    } else {
      point = c2.r_on && !c1.r_on ? j2 : j1;
    }
    result.p0 = result.p1 = point;
    return result;
  }
  // a proper segment: pick each end with one more exact comparison
  result.p0 = Orient3d(c1.p, c1.r, c2.p, c2.q) > 0 ? i2 : j1;
  result.p1 = Orient3d(c1.p, c1.q, c2.p, c2.r) < 0 ? j2 : i1;
  return result;
}

}  // namespace

bool TrianglesIntersect(const Triangle& a, const Triangle& b) {
  return Intersect(a, b, false).intersect;
}

TriangleIntersection IntersectTriangles(const Triangle& a, const Triangle& b) {
  return Intersect(a, b, true);
}

}  // namespace hapticd::geometry
