#include "server/geometry/penetration.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "server/geometry/gjk.h"

namespace hapticd::geometry {
namespace {

// Gauss-map tests within this of the boundary still count as crossing: such a pair
// only costs an extra (exactly evaluated) candidate, a missed one would cost accuracy.
constexpr double kArcTolerance = 1e-10;
// Edge pairs whose cross product is this small relative to the edges are parallel:
// their Minkowski sum is a segment, not a facet.
constexpr double kParallelSine2 = 1e-24;
// Vertices within this fraction of the size from a support plane join the contact
// feature that the witness points are taken from.
constexpr double kFeatureTolerance = 1e-10;

// Evaluates h(n) = min_B n.b - max_A n.a on candidate axes and keeps the best one.
class AxisSearch {
 public:
  AxisSearch(const ConvexHull& a, const ConvexHull& b) : support_a_(a), support_b_(b) {}

  // n must be unit. Both supports climb from the hints (-1: from the last supports);
  // h is formed from the support points' difference, so it stays accurate far from
  // the origin.
  void Try(const Vector3& n, int hint_a, int hint_b) {
    const SupportPoint pa = support_a_.Support(n, hint_a >= 0 ? hint_a : last_a_, nullptr);
    const SupportPoint pb = support_b_.Support(-n, hint_b >= 0 ? hint_b : last_b_, nullptr);
    last_a_ = pa.vertex, last_b_ = pb.vertex;
    const double h = n.dot(pb.point - pa.point);
    ++evaluated_;
    if (vertex_a_ < 0 || h > best_h_) best_h_ = h, normal_ = n, vertex_a_ = pa.vertex, vertex_b_ = pb.vertex;
  }
  // Both orientations of an axis of unknown sign; skips a zero axis.
  void TryBothWays(const Vector3& axis, int hint_a, int hint_b) {
    const double length = axis.norm();
    if (!(length > 0)) return;
    Try(axis / length, hint_a, hint_b);
    Try(-axis / length, hint_a, hint_b);
  }

  double best_h() const { return best_h_; }
  const Vector3& normal() const { return normal_; }
  int vertex_a() const { return vertex_a_; }
  int vertex_b() const { return vertex_b_; }
  int evaluated() const { return evaluated_; }

 private:
  HullSupport support_a_, support_b_;
  double best_h_ = -std::numeric_limits<double>::infinity();
  Vector3 normal_ = Vector3::UnitX();
  int vertex_a_ = -1, vertex_b_ = -1;
  int last_a_ = 0, last_b_ = 0;
  int evaluated_ = 0;
};

// An edge with the arc it spans on the Gauss map: from the normal of face fp to that
// of face fq (negated on the B side of B - A).
struct GaussArc {
  Vector3 p, q, q_cross_p, direction;
  int fp, fq, vertex;
};

// Arcs of a polyhedron's edges; flip negates the normals (for the B side of B - A).
std::vector<GaussArc> CollectArcs(const ConvexHull& hull, bool flip) {
  std::vector<GaussArc> arcs;
  arcs.reserve(hull.edges.size());
  const double sign = flip ? -1.0 : 1.0;
  for (size_t e = 0; e < hull.edges.size(); ++e) {
    const int fp = hull.edge_faces[e][0], fq = hull.edge_faces[e][1];
    const Vector3 p = sign * hull.face_normals[fp], q = sign * hull.face_normals[fq];
    const int i = hull.edges[e][0], j = hull.edges[e][1];
    arcs.push_back({p, q, q.cross(p), hull.vertices[j] - hull.vertices[i], fp, fq, i});
  }
  return arcs;
}

// Gregorius' test: arcs (a, b) and (c, d) cross when c and d lie on opposite sides
// of the plane of a and b, a and b on opposite sides of the plane of c and d, and the
// arcs are on the same hemisphere. Order-independent in a <-> b and c <-> d. cba and
// dba, the sides of c and d, come precomputed per face of b.
bool ArcsCross(const GaussArc& ab, const GaussArc& cd, double cba, double dba) {
  if (cba * dba > kArcTolerance) return false;
  const double adc = ab.p.dot(cd.q_cross_p), bdc = ab.q.dot(cd.q_cross_p);
  return adc * bdc <= kArcTolerance && cba * bdc >= -kArcTolerance;
}

// The faces of a hull as candidate axes: outward normals of a polyhedron (negated for
// b), both normals of a polygon.
void TryFaces(const ConvexHull& hull, bool is_b, AxisSearch& search) {
  if (hull.dimension == 2) {
    search.TryBothWays(hull.axis, is_b ? -1 : hull.faces[0][0], is_b ? hull.faces[0][0] : -1);
    return;
  }
  if (hull.dimension != 3) return;
  for (size_t f = 0; f < hull.faces.size(); ++f) {
    // a normal that underflowed to zero (coordinates far below the predicates' range)
    if (!(hull.face_normals[f].squaredNorm() > 0.5)) continue;
    const int v = hull.faces[f][0];
    if (is_b) {
      search.Try(-hull.face_normals[f], -1, v);
    } else {
      search.Try(hull.face_normals[f], v, -1);
    }
  }
}

double Size(const ConvexHull& a, const ConvexHull& b) {
  double size = 0;
  for (const ConvexHull* h : {&a, &b}) {
    Vector3 lo = h->vertices[0], hi = h->vertices[0];
    for (const Vector3& v : h->vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
    size = std::max(size, (hi - lo).maxCoeff());
  }
  return size;
}

}  // namespace

PenetrationResult CalcPenetration(const ConvexHull& a, const ConvexHull& b) {
  PenetrationResult result;
  if (a.num_vertices() == 0 || b.num_vertices() == 0) {
    result.depth = std::numeric_limits<double>::quiet_NaN();
    return result;
  }
  AxisSearch search(a, b);
  TryFaces(a, false, search);
  TryFaces(b, true, search);

  if (a.dimension == 3 && b.dimension == 3) {
    // two polyhedra: edge pairs whose Gauss-map arcs cross, oriented out of a
    const std::vector<GaussArc> arcs_a = CollectArcs(a, false), arcs_b = CollectArcs(b, true);
    std::vector<double> side(b.faces.size());
    for (const GaussArc& ea : arcs_a) {
      // which side of ea's great circle each (negated) normal of b lies on
      for (size_t g = 0; g < side.size(); ++g) side[g] = -b.face_normals[g].dot(ea.q_cross_p);
      for (const GaussArc& eb : arcs_b) {
        ++result.edge_pairs_tested;
        if (!ArcsCross(ea, eb, side[eb.fp], side[eb.fq])) continue;
        Vector3 n = ea.direction.cross(eb.direction);
        const double n2 = n.squaredNorm();
        if (!(n2 > kParallelSine2 * ea.direction.squaredNorm() * eb.direction.squaredNorm())) continue;
        n /= std::sqrt(n2);
        if (n.dot(ea.p + ea.q) < 0) n = -n;
        search.Try(n, ea.vertex, eb.vertex);
      }
    }
  } else {
    // a polygon, segment or point: every edge pair, both ways
    for (const auto& ea : a.edges) {
      for (const auto& eb : b.edges) {
        ++result.edge_pairs_tested;
        const Vector3 n = (a.vertices[ea[1]] - a.vertices[ea[0]]).cross(b.vertices[eb[1]] - b.vertices[eb[0]]);
        search.TryBothWays(n, ea[0], eb[0]);
      }
    }
    // points and segments only: D is a segment or a point, any normal of it will do
    if (a.dimension <= 1 && b.dimension <= 1) {
      const Vector3 u = a.dimension == 1 ? a.axis : b.dimension == 1 ? b.axis : Vector3::UnitX();
      Eigen::Index k = 0;
      u.cwiseAbs().minCoeff(&k);
      const Vector3 n1 = u.cross(Vector3::Unit(k)).normalized();
      search.TryBothWays(n1, -1, -1);
      search.TryBothWays(u.cross(n1), -1, -1);
    }
  }
  result.axes_evaluated = search.evaluated();
  result.depth = -search.best_h();
  result.normal = search.normal();

  // witness points: the contact features (vertices on the two support planes), with
  // b's moved by depth along the normal so the two overlap, and a common point by GJK
  const Vector3& n = result.normal;
  const Vector3 top_a = a.vertices[search.vertex_a()], bottom_b = b.vertices[search.vertex_b()];
  const double tolerance = kFeatureTolerance * Size(a, b);
  std::vector<Vector3> feature_a, feature_b;
  for (const Vector3& v : a.vertices) {
    if (n.dot(v - top_a) >= -tolerance) feature_a.push_back(v);
  }
  for (const Vector3& v : b.vertices) {
    if (n.dot(v - bottom_b) <= tolerance) feature_b.push_back(v + result.depth * n);
  }
  if (feature_a.empty()) feature_a.push_back(top_a);
  if (feature_b.empty()) feature_b.push_back(bottom_b + result.depth * n);
  const GjkResult common = CalcGjkDistance(PointSetSupport(feature_a), PointSetSupport(feature_b));
  result.point_a = common.point_a;
  result.point_b = common.point_b - result.depth * n;
  return result;
}

}  // namespace hapticd::geometry
