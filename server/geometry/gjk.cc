#include "server/geometry/gjk.h"

#include <cmath>
#include <limits>

#include "server/geometry/work_meter.h"

namespace hapticd::geometry {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// |v| below this fraction of the simplex's extent counts as the origin itself.
constexpr double kTouchRelative = 1e-14;

// Unit vector along dir, or +x for a zero (or non-finite) dir.
Vector3 UnitOrX(const Vector3& dir) {
  const double n = dir.norm();
  return n > 0 && std::isfinite(n) ? Vector3(dir / n) : Vector3(Vector3::UnitX());
}

// One simplex vertex: the point w = b - a of the Minkowski difference and its origin.
struct SimplexVertex {
  Vector3 w, a, b;
  int vertex_a = -1, vertex_b = -1;
};

// The point of a simplex nearest the origin, as weights on a subset of its vertices.
struct SubSimplex {
  int size = 0;
  std::array<int, 4> index = {0, 0, 0, 0};
  std::array<double, 4> lambda = {0, 0, 0, 0};
  double distance_squared = kInf;
};

bool SameSign(double x, double y) { return (x > 0 && y > 0) || (x < 0 && y < 0); }

SubSimplex AtVertex(const Vector3* s, int i) {
  SubSimplex r;
  r.size = 1;
  r.index[0] = i;
  r.lambda[0] = 1;
  r.distance_squared = s[i].squaredNorm();
  return r;
}

// Segment s_i s_j: the origin's projection parameter decides between the interior and
// the nearer end (a zero-length segment is its first end).
SubSimplex SolveSegment(const Vector3* s, int i, int j) {
  const Vector3 t = s[j] - s[i];
  const double tt = t.squaredNorm();
  if (!(tt > 0)) return AtVertex(s, i);
  const double u = -s[i].dot(t) / tt;
  if (!(u > 0)) return AtVertex(s, i);
  if (!(u < 1)) return AtVertex(s, j);
  SubSimplex r;
  r.size = 2;
  r.index = {i, j, 0, 0};
  r.lambda = {1 - u, u, 0, 0};
  r.distance_squared = ((1 - u) * s[i] + u * s[j]).squaredNorm();
  return r;
}

SubSimplex Nearer(const SubSimplex& x, const SubSimplex& y) {
  return y.distance_squared < x.distance_squared ? y : x;
}

// Triangle s_i s_j s_k (Montanari's S2D): project the origin onto the plane and
// compare the signed areas of the three sub-triangles with the whole one, in the
// coordinate plane where the triangle's projection is largest. Where a sub-area has
// the wrong sign (or is zero) the origin lies beyond the opposite edge: recurse.
SubSimplex SolveTriangle(const Vector3* s, int i, int j, int k) {
  const Vector3 n = (s[j] - s[i]).cross(s[k] - s[i]);
  Eigen::Index m = 0;
  const double largest = n.cwiseAbs().maxCoeff(&m);
  const int u = static_cast<int>((m + 1) % 3), v = static_cast<int>((m + 2) % 3);
  // rounded to collinear: the best of the edges
  if (!(largest > 0)) {
    return Nearer(Nearer(SolveSegment(s, i, j), SolveSegment(s, j, k)), SolveSegment(s, k, i));
  }
  const Vector3 p0 = n * (s[i].dot(n) / n.squaredNorm());
  const auto area = [u, v](const Vector3& a, const Vector3& b, const Vector3& c) {
    return (b[u] - a[u]) * (c[v] - a[v]) - (b[v] - a[v]) * (c[u] - a[u]);
  };
  const double mu = area(s[i], s[j], s[k]);
  const std::array<double, 3> c = {area(p0, s[j], s[k]), area(s[i], p0, s[k]), area(s[i], s[j], p0)};
  if (SameSign(mu, c[0]) && SameSign(mu, c[1]) && SameSign(mu, c[2])) {
    SubSimplex r;
    r.size = 3;
    r.index = {i, j, k, 0};
    r.lambda = {c[0] / mu, c[1] / mu, c[2] / mu, 0};
    r.distance_squared = (r.lambda[0] * s[i] + r.lambda[1] * s[j] + r.lambda[2] * s[k]).squaredNorm();
    return r;
  }
  SubSimplex best;
  if (!SameSign(mu, c[0])) best = Nearer(best, SolveSegment(s, j, k));
  if (!SameSign(mu, c[1])) best = Nearer(best, SolveSegment(s, k, i));
  if (!SameSign(mu, c[2])) best = Nearer(best, SolveSegment(s, i, j));
  return best;
}

// Tetrahedron (Montanari's S3D): the cofactors C_j are the signed volumes with vertex
// j replaced by the origin; all of one sign with their sum means the origin is inside.
// Otherwise the origin lies beyond each face whose cofactor disagrees: recurse.
SubSimplex SolveTetrahedron(const Vector3* s) {
  const auto det = [](const Vector3& a, const Vector3& b, const Vector3& c) { return a.dot(b.cross(c)); };
  const std::array<double, 4> c = {det(s[1], s[2], s[3]), -det(s[0], s[2], s[3]), det(s[0], s[1], s[3]),
                                   -det(s[0], s[1], s[2])};
  const double volume = c[0] + c[1] + c[2] + c[3];
  if (SameSign(volume, c[0]) && SameSign(volume, c[1]) && SameSign(volume, c[2]) && SameSign(volume, c[3])) {
    SubSimplex r;
    r.size = 4;
    r.index = {0, 1, 2, 3};
    for (int q = 0; q < 4; ++q) r.lambda[q] = c[q] / volume;
    r.distance_squared = 0;
    return r;
  }
  SubSimplex best;
  if (!SameSign(volume, c[0])) best = Nearer(best, SolveTriangle(s, 1, 2, 3));
  if (!SameSign(volume, c[1])) best = Nearer(best, SolveTriangle(s, 0, 2, 3));
  if (!SameSign(volume, c[2])) best = Nearer(best, SolveTriangle(s, 0, 1, 3));
  if (!SameSign(volume, c[3])) best = Nearer(best, SolveTriangle(s, 0, 1, 2));
  return best;
}

// The simplex, reduced to the vertices that carry its point nearest the origin.
struct Simplex {
  std::array<SimplexVertex, 4> y;
  std::array<double, 4> lambda = {1, 0, 0, 0};
  int size = 0;
  Vector3 v = Vector3::Zero();  // nearest point, sum of lambda_i w_i
  double vv = kInf;

  void Reduce() {
    std::array<Vector3, 4> w;
    for (int i = 0; i < size; ++i) w[i] = y[i].w;
    SubSimplex sub;
    if (size == 1) sub = AtVertex(w.data(), 0);
    if (size == 2) sub = SolveSegment(w.data(), 0, 1);
    if (size == 3) sub = SolveTriangle(w.data(), 0, 1, 2);
    if (size == 4) sub = SolveTetrahedron(w.data());
    // nothing usable (non-finite input): keep the newest vertex alone
    if (sub.size == 0) sub = AtVertex(w.data(), size - 1);
    std::array<SimplexVertex, 4> kept;
    v.setZero();
    for (int i = 0; i < sub.size; ++i) {
      kept[i] = y[sub.index[i]];
      lambda[i] = sub.lambda[i];
      v += lambda[i] * kept[i].w;
    }
    y = kept;
    size = sub.size;
    vv = sub.size == 4 ? 0 : v.squaredNorm();
  }
  bool Contains(const SimplexVertex& s) const {
    for (int i = 0; i < size; ++i) {
      const bool indexed = s.vertex_a >= 0 && s.vertex_b >= 0;
      if (indexed ? (y[i].vertex_a == s.vertex_a && y[i].vertex_b == s.vertex_b) : y[i].w == s.w) return true;
    }
    return false;
  }
  double ExtentSquared() const {
    double e = 0;
    for (int i = 0; i < size; ++i) e = std::max(e, y[i].w.squaredNorm());
    return e;
  }
};

}  // namespace

SupportPoint PointSetSupport::Support(const Vector3& dir, int, int* visits) const {
  SupportPoint best;
  double best_value = -kInf;
  for (size_t i = 0; i < points_.size(); ++i) {
    const double value = dir.dot(points_[i]);
    if (best.vertex < 0 || value > best_value) best = {points_[i], static_cast<int>(i)}, best_value = value;
  }
  if (visits) *visits += static_cast<int>(points_.size());
  return best;
}

bool PointSetSupport::GetVertex(int vertex, Vector3* point) const {
  if (vertex < 0 || vertex >= static_cast<int>(points_.size())) return false;
  *point = points_[vertex];
  return true;
}

SupportPoint HullSupport::Support(const Vector3& dir, int hint, int* visits) const {
  const ConvexHull& hull = *hull_;
  const int n = hull.num_vertices();
  if (n == 0) return {Vector3::Constant(std::numeric_limits<double>::quiet_NaN()), -1};
  const Vector3 d = R_WH_.transpose() * dir;
  int current = hint >= 0 && hint < n ? hint : 0;
  double best = d.dot(hull.vertices[current]);
  int count = 1;
  // steepest ascent along hull edges; values strictly increase, so it ends
  for (;;) {
    int next = -1;
    for (int u : hull.neighbors(current)) {
      ++count;
      const double value = d.dot(hull.vertices[u]);
      if (value > best) best = value, next = u;
    }
    if (next < 0) break;
    current = next;
  }
  if (visits) *visits += count;
  return {R_WH_ * hull.vertices[current] + p_WH_, current};
}

bool HullSupport::GetVertex(int vertex, Vector3* point) const {
  if (vertex < 0 || vertex >= hull_->num_vertices()) return false;
  *point = R_WH_ * hull_->vertices[vertex] + p_WH_;
  return true;
}

SupportPoint SphereSupport::Support(const Vector3& dir, int, int* visits) const {
  if (visits) ++*visits;
  return {sphere_.center + sphere_.radius * UnitOrX(dir), -1};
}

SupportPoint BoxSupport::Support(const Vector3& dir, int, int* visits) const {
  int corner = 0;
  for (int k = 0; k < 3; ++k) {
    if (dir.dot(box_.rotation.col(k)) > 0) corner |= 1 << k;
  }
  if (visits) ++*visits;
  SupportPoint s{Vector3::Zero(), corner};
  GetVertex(corner, &s.point);
  return s;
}

bool BoxSupport::GetVertex(int vertex, Vector3* point) const {
  if (vertex < 0 || vertex > 7) return false;
  Vector3 p = box_.center;
  for (int k = 0; k < 3; ++k) p += ((vertex >> k) & 1 ? 1.0 : -1.0) * box_.half_extents[k] * box_.rotation.col(k);
  *point = p;
  return true;
}

SupportPoint CapsuleSupport::Support(const Vector3& dir, int, int* visits) const {
  if (visits) ++*visits;
  const Vector3& end = dir.dot(capsule_.p1 - capsule_.p0) > 0 ? capsule_.p1 : capsule_.p0;
  return {end + capsule_.radius * UnitOrX(dir), -1};
}

GjkResult CalcGjkDistance(const SupportMap& a, const SupportMap& b, const GjkSimplex* warm_start,
                          const GjkOptions& options) {
  GjkResult result;
  int hint_a = -1, hint_b = -1;
  // support point of B - A along d: b's farthest along d minus a's farthest along -d
  // each search charged to the thread's work meter, a unit per eight vertices examined
  const auto support = [&](const Vector3& d) {
    const int visits_before = result.support_visits;
    const SupportPoint sb = b.Support(d, hint_b, &result.support_visits);
    const SupportPoint sa = a.Support(-d, hint_a, &result.support_visits);
    WorkMeter::Charge((result.support_visits - visits_before + 7) / 8);
    hint_a = sa.vertex, hint_b = sb.vertex;
    return SimplexVertex{sb.point - sa.point, sa.point, sb.point, sa.vertex, sb.vertex};
  };

  // start from the warm simplex, re-evaluated at the current poses, when it has one
  Simplex simplex;
  if (warm_start != nullptr && warm_start->size > 0 && warm_start->size <= 4) {
    for (int i = 0; i < warm_start->size; ++i) {
      SimplexVertex& s = simplex.y[i];
      s.vertex_a = warm_start->vertex_a[i], s.vertex_b = warm_start->vertex_b[i];
      if (!a.GetVertex(s.vertex_a, &s.a) || !b.GetVertex(s.vertex_b, &s.b)) break;
      s.w = s.b - s.a;
      simplex.size = i + 1;
    }
    if (simplex.size != warm_start->size) simplex.size = 0;
    if (simplex.size > 0) hint_a = simplex.y[0].vertex_a, hint_b = simplex.y[0].vertex_b;
  }
  if (simplex.size == 0) simplex.y[simplex.size++] = support(Vector3::UnitX());
  simplex.Reduce();

  const double touch2 = kTouchRelative * kTouchRelative;
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    // a spent work budget: the answer so far (its tick is thrown away)
    if (WorkMeter::Exhausted()) break;
    // the origin is in the simplex, or within rounding of it: touching or overlapping
    if (simplex.size == 4 || simplex.vv <= touch2 * simplex.ExtentSquared()) {
      result.intersect = true;
      break;
    }
    result.iterations = iteration + 1;
    const SimplexVertex w = support(-simplex.v);
    // converged: nothing of B - A lies nearer the origin along v than v itself (to
    // the relative tolerance), or the support point repeats
    if (simplex.vv - simplex.v.dot(w.w) <= options.relative_tolerance * simplex.vv) break;
    if (simplex.Contains(w)) break;
    const Simplex previous = simplex;
    simplex.y[simplex.size++] = w;
    simplex.Reduce();
    // no progress (rounding): keep the better simplex and stop
    if (!(simplex.vv < previous.vv)) {
      simplex = previous;
      break;
    }
  }

  // witness points from the final weights
  result.point_a.setZero();
  result.point_b.setZero();
  bool indexed = true;
  for (int i = 0; i < simplex.size; ++i) {
    result.point_a += simplex.lambda[i] * simplex.y[i].a;
    result.point_b += simplex.lambda[i] * simplex.y[i].b;
    result.simplex.vertex_a[i] = simplex.y[i].vertex_a;
    result.simplex.vertex_b[i] = simplex.y[i].vertex_b;
    indexed = indexed && simplex.y[i].vertex_a >= 0 && simplex.y[i].vertex_b >= 0;
  }
  result.simplex.size = indexed ? simplex.size : 0;
  if (!result.intersect) {
    result.distance = std::sqrt(simplex.vv);
    result.normal = UnitOrX(simplex.v);
  }
  return result;
}

}  // namespace hapticd::geometry
