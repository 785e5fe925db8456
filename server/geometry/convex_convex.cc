#include "server/geometry/convex_convex.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "server/geometry/exact_predicates.h"
#include "server/geometry/gjk.h"
#include "server/geometry/penetration.h"

namespace hapticd::geometry {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Distances within this fraction of the coordinates' magnitude (plus the size) go to
// the exact test: about 1e6 times the rounding of GJK and of the candidate axes.
constexpr double kContactBand = 1e-10;
// Depths of hulls that do intersect below this fraction (a few roundings of the
// candidate axes' evaluation) are reported as exactly 0: touching.
constexpr double kTouchBand = 16 * std::numeric_limits<double>::epsilon();

// Drops coordinate k, keeping the cyclic order (Orient2d then equals the sign of the
// k-th component of the 3D normal).
Vector2 Drop(const Vector3& v, int k) { return {v[(k + 1) % 3], v[(k + 2) % 3]}; }

// A coordinate plane on which the non-degenerate triangle a, b, c projects to a
// non-degenerate triangle (exactly).
int ProjectionAxis(const Vector3& a, const Vector3& b, const Vector3& c) {
  Eigen::Index k = 0;
  (b - a).cross(c - a).cwiseAbs().maxCoeff(&k);
  for (int tries = 0; tries < 3; ++tries) {
    const int axis = static_cast<int>((k + tries) % 3);
    if (Orient2d(Drop(a, axis), Drop(b, axis), Drop(c, axis)) != 0) return axis;
  }
  return static_cast<int>(k);
}

// r on the closed segment pq, given that the three are collinear (exact comparisons).
bool Between(const Vector2& p, const Vector2& q, const Vector2& r) {
  return std::min(p.x(), q.x()) <= r.x() && r.x() <= std::max(p.x(), q.x()) && std::min(p.y(), q.y()) <= r.y() &&
         r.y() <= std::max(p.y(), q.y());
}

// Closed segments pq and rs in the plane share a point.
bool SegmentsIntersect2d(const Vector2& p, const Vector2& q, const Vector2& r, const Vector2& s) {
  const int o1 = Orient2d(p, q, r), o2 = Orient2d(p, q, s), o3 = Orient2d(r, s, p), o4 = Orient2d(r, s, q);
  if (o1 * o2 < 0 && o3 * o4 < 0) return true;
  // touching: an endpoint on the other segment
  return (o1 == 0 && Between(p, q, r)) || (o2 == 0 && Between(p, q, s)) || (o3 == 0 && Between(r, s, p)) ||
         (o4 == 0 && Between(r, s, q));
}

// Closed triangle abc (non-degenerate) and point x, all in one plane.
bool InTriangle2d(const Vector2& a, const Vector2& b, const Vector2& c, const Vector2& x) {
  const int s = Orient2d(a, b, c);
  return s * Orient2d(a, b, x) >= 0 && s * Orient2d(b, c, x) >= 0 && s * Orient2d(c, a, x) >= 0;
}

// Closed segment pq meets closed triangle abc (non-degenerate), exactly.
bool SegmentTouchesTriangle(const Vector3& p, const Vector3& q, const Vector3& a, const Vector3& b,
                            const Vector3& c) {
  const int sp = Orient3d(a, b, c, p), sq = Orient3d(a, b, c, q);
  if (sp * sq > 0) return false;
  // coplanar: a 2D test in a projection that keeps the triangle a triangle
  if (sp == 0 && sq == 0) {
    const int k = ProjectionAxis(a, b, c);
    const Vector2 p2 = Drop(p, k), q2 = Drop(q, k), a2 = Drop(a, k), b2 = Drop(b, k), c2 = Drop(c, k);
    return InTriangle2d(a2, b2, c2, p2) || InTriangle2d(a2, b2, c2, q2) || SegmentsIntersect2d(p2, q2, a2, b2) ||
           SegmentsIntersect2d(p2, q2, b2, c2) || SegmentsIntersect2d(p2, q2, c2, a2);
  }
  // one crossing point: the line passes every edge on the same side (or along it)
  const int s1 = Orient3d(p, q, a, b), s2 = Orient3d(p, q, b, c), s3 = Orient3d(p, q, c, a);
  return (s1 >= 0 && s2 >= 0 && s3 >= 0) || (s1 <= 0 && s2 <= 0 && s3 <= 0);
}

// Closed segments pq and rs in space (p != q, r != s) share a point, exactly.
bool SegmentsIntersect3d(const Vector3& p, const Vector3& q, const Vector3& r, const Vector3& s) {
  if (Orient3d(p, q, r, s) != 0) return false;
  // all four collinear: overlapping intervals along the line's widest coordinate
  if (IsDegenerateTriangle(p, q, r) && IsDegenerateTriangle(p, q, s)) {
    Eigen::Index k = 0;
    (q - p).cwiseAbs().maxCoeff(&k);
    return std::max(std::min(p[k], q[k]), std::min(r[k], s[k])) <= std::min(std::max(p[k], q[k]), std::max(r[k], s[k]));
  }
  const int k = IsDegenerateTriangle(p, q, r) ? ProjectionAxis(p, q, s) : ProjectionAxis(p, q, r);
  return SegmentsIntersect2d(Drop(p, k), Drop(q, k), Drop(r, k), Drop(s, k));
}

// Closed hull contains x, exactly.
bool HullContains(const ConvexHull& h, const Vector3& x) {
  const auto& v = h.vertices;
  switch (h.dimension) {
    case 0:
      return x == v[0];
    case 1: {
      if (!IsDegenerateTriangle(v[0], v[1], x)) return false;
      Eigen::Index k = 0;
      (v[1] - v[0]).cwiseAbs().maxCoeff(&k);
      return std::min(v[0][k], v[1][k]) <= x[k] && x[k] <= std::max(v[0][k], v[1][k]);
    }
    case 2: {
      if (Orient3d(v[0], v[1], v[2], x) != 0) return false;
      const int k = ProjectionAxis(v[0], v[1], v[2]);
      const int s = Orient2d(Drop(v[0], k), Drop(v[1], k), Drop(v[2], k));
      const int m = h.num_vertices();
      for (int i = 0; i < m; ++i) {
        if (s * Orient2d(Drop(v[i], k), Drop(v[(i + 1) % m], k), Drop(x, k)) < 0) return false;
      }
      return true;
    }
    case 3:
      for (const auto& f : h.faces) {
        if (Orient3d(v[f[0]], v[f[1]], v[f[2]], x) > 0) return false;
      }
      return true;
    default:
      return false;
  }
}

// A slab {x : lo <= n.x <= hi} (widened by margin) known to contain a ∩ b: features
// of a entirely below it, or of b entirely above it, cannot meet the other hull.
struct Slab {
  Vector3 n = Vector3::Zero();
  double lo = -kInf, hi = kInf, margin = 0;
  bool ReachesFromA(double top) const { return top >= lo - margin; }
  bool ReachesFromB(double bottom) const { return bottom <= hi + margin; }
};

// The exact test. A nonempty a ∩ b has a vertex; at that vertex either a vertex of
// one hull lies in the other, or an edge of one meets a closed face (triangle) of the
// other, or (hulls without faces) two edges meet.
bool IntersectExactly(const ConvexHull& a, const ConvexHull& b, const Slab& slab) {
  const auto top = [&](std::initializer_list<Vector3> pts) {
    double t = -kInf;
    for (const Vector3& p : pts) t = std::max(t, slab.n.dot(p));
    return t;
  };
  const auto bottom = [&](std::initializer_list<Vector3> pts) {
    double t = kInf;
    for (const Vector3& p : pts) t = std::min(t, slab.n.dot(p));
    return t;
  };
  const auto& va = a.vertices;
  const auto& vb = b.vertices;
  // a vertex of one inside the other
  for (const Vector3& v : va) {
    if (slab.ReachesFromA(slab.n.dot(v)) && HullContains(b, v)) return true;
  }
  for (const Vector3& v : vb) {
    if (slab.ReachesFromB(slab.n.dot(v)) && HullContains(a, v)) return true;
  }
  // an edge of one through a face of the other
  for (const auto& e : a.edges) {
    if (!slab.ReachesFromA(top({va[e[0]], va[e[1]]}))) continue;
    for (const auto& f : b.faces) {
      if (slab.ReachesFromB(bottom({vb[f[0]], vb[f[1]], vb[f[2]]})) &&
          SegmentTouchesTriangle(va[e[0]], va[e[1]], vb[f[0]], vb[f[1]], vb[f[2]])) {
        return true;
      }
    }
  }
  for (const auto& e : b.edges) {
    if (!slab.ReachesFromB(bottom({vb[e[0]], vb[e[1]]}))) continue;
    for (const auto& f : a.faces) {
      if (slab.ReachesFromA(top({va[f[0]], va[f[1]], va[f[2]]})) &&
          SegmentTouchesTriangle(vb[e[0]], vb[e[1]], va[f[0]], va[f[1]], va[f[2]])) {
        return true;
      }
    }
  }
  // two segments (faces cover every other edge-edge contact)
  if (a.faces.empty() && b.faces.empty()) {
    for (const auto& ea : a.edges) {
      for (const auto& eb : b.edges) {
        if (SegmentsIntersect3d(va[ea[0]], va[ea[1]], vb[eb[0]], vb[eb[1]])) return true;
      }
    }
  }
  return false;
}

// Largest coordinate magnitude and largest bounding-box side of the two hulls.
void Scales(const ConvexHull& a, const ConvexHull& b, double* magnitude, double* size) {
  *magnitude = 0;
  *size = 0;
  for (const ConvexHull* h : {&a, &b}) {
    Vector3 lo = h->vertices[0], hi = h->vertices[0];
    for (const Vector3& v : h->vertices) {
      lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
      *magnitude = std::max(*magnitude, v.cwiseAbs().maxCoeff());
    }
    *size = std::max(*size, (hi - lo).maxCoeff());
  }
}

}  // namespace

bool HullsIntersect(const ConvexHull& a, const ConvexHull& b) {
  if (a.num_vertices() == 0 || b.num_vertices() == 0) return false;
  return IntersectExactly(a, b, Slab{});
}

ConvexConvexResult CollideHulls(const ConvexHull& a, const ConvexHull& b) {
  ConvexConvexResult result;
  if (a.num_vertices() == 0 || b.num_vertices() == 0) {
    result.distance = std::numeric_limits<double>::quiet_NaN();
    return result;
  }
  double magnitude = 0, size = 0;
  Scales(a, b, &magnitude, &size);
  const double band = kContactBand * (magnitude + size);

  // clearly apart: GJK has the answer
  const GjkResult gjk = CalcGjkDistance(HullSupport(a), HullSupport(b));
  if (!gjk.intersect && gjk.distance > band) {
    return {false, gjk.distance, gjk.normal, gjk.point_a, gjk.point_b};
  }
  // clearly overlapping: the penetration depth has the answer
  const PenetrationResult pen = CalcPenetration(a, b);
  if (pen.depth > band) return {true, -pen.depth, pen.normal, pen.point_a, pen.point_b};

  // within rounding of contact: decide exactly, on the features near the best axis'
  // support planes (a ∩ b lies between them)
  Slab slab;
  slab.n = pen.normal;
  slab.hi = -kInf, slab.lo = kInf;
  for (const Vector3& v : a.vertices) slab.hi = std::max(slab.hi, slab.n.dot(v));
  for (const Vector3& v : b.vertices) slab.lo = std::min(slab.lo, slab.n.dot(v));
  slab.margin = band;
  if (IntersectExactly(a, b, slab)) {
    const double depth = pen.depth > kTouchBand * (magnitude + size) ? pen.depth : 0.0;
    return {true, -depth, pen.normal, pen.point_a, pen.point_b};
  }
  // exactly apart, by less than the band
  if (!gjk.intersect && gjk.distance >= -pen.depth) {
    return {false, gjk.distance, gjk.normal, gjk.point_a, gjk.point_b};
  }
  return {false, std::max(-pen.depth, 0.0), pen.normal, pen.point_a, pen.point_b};
}

ConvexConvexResult CollideConvex(const std::vector<Vector3>& points_a, const std::vector<Vector3>& points_b) {
  return CollideHulls(BuildConvexHull(points_a), BuildConvexHull(points_b));
}

}  // namespace hapticd::geometry
