#include "server/geometry/triangle_triangle.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/exact_predicates.h"
#include "server/geometry/segment_triangle.h"

namespace hapticd::geometry {
namespace {

Triangle Tri(const Vector3& a, const Vector3& b, const Vector3& c) { return {a, b, c}; }

// ---------------------------------------------------------------------------------
// An exact oracle on small integer coordinates: the separating axis theorem. Two
// closed triangles are disjoint iff some axis among n_a, n_b, e_a x e_b, n_a x e_a
// and n_b x e_b (the facet normals of their Minkowski difference, in 3D or in their
// common plane) separates their projections strictly. All in int64, no rounding.
using I3 = std::array<int64_t, 3>;
struct ITri {
  I3 v[3];
};

I3 Sub(const I3& a, const I3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
I3 Cross(const I3& a, const I3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
int64_t Dot(const I3& a, const I3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
bool IsZero(const I3& a) { return a[0] == 0 && a[1] == 0 && a[2] == 0; }
I3 Normal(const ITri& t) { return Cross(Sub(t.v[1], t.v[0]), Sub(t.v[2], t.v[0])); }
I3 Edge(const ITri& t, int i) { return Sub(t.v[(i + 1) % 3], t.v[i]); }

bool SeparatesStrictly(const I3& axis, const ITri& a, const ITri& b) {
  if (IsZero(axis)) return false;
  int64_t min_a = std::numeric_limits<int64_t>::max(), max_a = std::numeric_limits<int64_t>::min();
  int64_t min_b = min_a, max_b = max_a;
  for (int i = 0; i < 3; ++i) {
    min_a = std::min(min_a, Dot(axis, a.v[i]));
    max_a = std::max(max_a, Dot(axis, a.v[i]));
    min_b = std::min(min_b, Dot(axis, b.v[i]));
    max_b = std::max(max_b, Dot(axis, b.v[i]));
  }
  return max_a < min_b || max_b < min_a;
}

bool OracleIntersect(const ITri& a, const ITri& b) {
  const I3 na = Normal(a), nb = Normal(b);
  std::vector<I3> axes = {na, nb};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) axes.push_back(Cross(Edge(a, i), Edge(b, j)));
    axes.push_back(Cross(na, Edge(a, i)));
    axes.push_back(Cross(nb, Edge(b, i)));
  }
  for (const I3& axis : axes) {
    if (SeparatesStrictly(axis, a, b)) return false;
  }
  return true;
}

bool OracleCoplanar(const ITri& a, const ITri& b) {
  const I3 na = Normal(a);
  for (int i = 0; i < 3; ++i) {
    if (Dot(na, Sub(b.v[i], a.v[0])) != 0) return false;
  }
  return true;
}

// Sign of ((b - a) x (c - a)) . (d - a) in integers.
int IOrient(const I3& a, const I3& b, const I3& c, const I3& d) {
  const int64_t x = Dot(Cross(Sub(b, a), Sub(c, a)), Sub(d, a));
  return (x > 0) - (x < 0);
}

// The points that bound a non-coplanar intersection: transversal edge crossings of
// the other triangle, and vertices lying in the other's plane inside it. Exact
// decisions in integers, points in double (the one rounding is the final division).
std::vector<Vector3> OracleBoundaryPoints(const ITri& a, const ITri& b, double scale) {
  std::vector<Vector3> points;
  const auto to_vector = [scale](const I3& p) {
    return Vector3(p[0] * scale, p[1] * scale, p[2] * scale);
  };
  const auto add_for = [&](const ITri& x, const ITri& y) {
    const I3 ny = Normal(y);
    for (int i = 0; i < 3; ++i) {
      const I3& p = x.v[i];
      const I3& q = x.v[(i + 1) % 3];
      const int64_t dp = Dot(ny, Sub(p, y.v[0]));
      const int64_t dq = Dot(ny, Sub(q, y.v[0]));
      // a vertex in y's plane: inside y (closed) when it is on no edge's outer side
      if (dp == 0) {
        int s[3];
        for (int k = 0; k < 3; ++k) {
          const I3 c = Cross(Sub(y.v[(k + 1) % 3], y.v[k]), Sub(p, y.v[k]));
          const int64_t side = Dot(c, ny);
          s[k] = (side > 0) - (side < 0);
        }
        if (s[0] >= 0 && s[1] >= 0 && s[2] >= 0) points.push_back(to_vector(p));
      }
      // a transversal crossing strictly between the endpoints
      if ((dp > 0 && dq < 0) || (dp < 0 && dq > 0)) {
        const int s0 = IOrient(p, q, y.v[0], y.v[1]);
        const int s1 = IOrient(p, q, y.v[1], y.v[2]);
        const int s2 = IOrient(p, q, y.v[2], y.v[0]);
        const bool inside = (s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0);
        if (inside) {
          const double t = static_cast<double>(dp) / static_cast<double>(dp - dq);
          points.push_back(to_vector(p) + t * (to_vector(q) - to_vector(p)));
        }
      }
    }
  };
  add_for(a, b);
  add_for(b, a);
  return points;
}

Triangle ToTriangle(const ITri& t, double scale, const Vector3& offset) {
  Triangle r;
  Vector3* out[] = {&r.v0, &r.v1, &r.v2};
  for (int i = 0; i < 3; ++i) {
    *out[i] = Vector3(t.v[i][0] * scale, t.v[i][1] * scale, t.v[i][2] * scale) + offset;
  }
  return r;
}

// Random integer triangles in [-range, range]^3, often sharing a vertex or an edge
// point with the other, so touching and coplanar configurations are common.
ITri RandomITri(std::mt19937_64& rng, int range) {
  std::uniform_int_distribution<int64_t> coord(-range, range);
  while (true) {
    ITri t;
    for (auto& v : t.v) v = {coord(rng), coord(rng), coord(rng)};
    if (!IsZero(Normal(t))) return t;
  }
}

ITri RandomITriNear(std::mt19937_64& rng, const ITri& other, int range) {
  std::uniform_int_distribution<int> pick(0, 5);
  ITri t = RandomITri(rng, range);
  const int mode = pick(rng);
  if (mode == 0) t.v[0] = other.v[rng() % 3];                 // a shared vertex
  if (mode == 1) {                                            // shared edge endpoints
    t.v[0] = other.v[0];
    t.v[1] = other.v[1];
  }
  if (mode == 2) {                                            // coplanar: same plane
    const I3 n = Normal(other);
    for (auto& v : t.v) {
      // walk the random point into the plane along an axis where n has a unit-ish step
      for (int tries = 0; tries < 64 && Dot(n, Sub(v, other.v[0])) != 0; ++tries) {
        v = {other.v[0][0] + (int64_t)(rng() % 5) - 2, other.v[0][1] + (int64_t)(rng() % 5) - 2,
             other.v[0][2] + (int64_t)(rng() % 5) - 2};
      }
    }
  }
  if (IsZero(Normal(t))) return RandomITri(rng, range);
  return t;
}

// All 6 vertex orders of a triangle (3 rotations, each also mirrored).
std::array<Triangle, 6> Orders(const Triangle& t) {
  return {Tri(t.v0, t.v1, t.v2), Tri(t.v1, t.v2, t.v0), Tri(t.v2, t.v0, t.v1),
          Tri(t.v0, t.v2, t.v1), Tri(t.v2, t.v1, t.v0), Tri(t.v1, t.v0, t.v2)};
}

double DistanceToTriangle(const Vector3& p, const Triangle& t) {
  return std::sqrt(FindClosestPointOnTriangle(p, t).distance_squared);
}

double DistanceToSegment(const Vector3& x, const Vector3& a, const Vector3& b) {
  const Vector3 d = b - a;
  const double len2 = d.squaredNorm();
  const double s = len2 > 0 ? std::clamp((x - a).dot(d) / len2, 0.0, 1.0) : 0.0;
  return (x - (a + s * d)).norm();
}

// Checks the reported segment against the oracle's boundary points: each endpoint is
// one of them (it bounds the intersection), every one of them lies on the segment,
// and the segment collapses to a point exactly when they all coincide.
void ExpectSegmentMatches(const TriangleIntersection& r, const std::vector<Vector3>& points,
                          double tol, const char* what) {
  ASSERT_FALSE(points.empty()) << what;
  double diameter = 0;
  for (const Vector3& x : points) {
    for (const Vector3& y : points) diameter = std::max(diameter, (x - y).norm());
  }
  double near0 = std::numeric_limits<double>::infinity(), near1 = near0;
  for (const Vector3& x : points) {
    EXPECT_LE(DistanceToSegment(x, r.p0, r.p1), tol) << what;
    near0 = std::min(near0, (x - r.p0).norm());
    near1 = std::min(near1, (x - r.p1).norm());
  }
  EXPECT_LE(near0, tol) << what;
  EXPECT_LE(near1, tol) << what;
  if (diameter <= tol) {
    EXPECT_EQ(r.p0, r.p1) << what << ": a single touching point must be reported twice";
  } else {
    EXPECT_NE(r.p0, r.p1) << what;
  }
}

// ---------------------------------------------------------------------------------
// Hand-built cases, all in dyadic coordinates so every answer is exact.

const Triangle kBase = Tri({0, 0, 0}, {4, 0, 0}, {0, 4, 0});

TEST(TriangleTriangle, CrossingGivesTheOverlapOfBothIntervals) {
  // b stands in the plane y = 1; it meets z = 0 on x in [1, 3], a on x in [0, 3]
  const Triangle b = Tri({1, 1, -2}, {1, 1, 2}, {3, 1, 0});
  const TriangleIntersection r = IntersectTriangles(kBase, b);
  ASSERT_TRUE(r.intersect);
  EXPECT_FALSE(r.coplanar);
  const Vector3 lo(1, 1, 0), hi(3, 1, 0);
  EXPECT_TRUE((r.p0 == lo && r.p1 == hi) || (r.p0 == hi && r.p1 == lo))
      << r.p0.transpose() << " / " << r.p1.transpose();
}

TEST(TriangleTriangle, SeparatedParallelPlanesMiss) {
  const Triangle b = Tri({0, 0, 1}, {4, 0, 1}, {0, 4, 1});
  EXPECT_FALSE(TrianglesIntersect(kBase, b));
  EXPECT_FALSE(IntersectTriangles(kBase, b).intersect);
}

TEST(TriangleTriangle, SharedVertexTouchesAtThatPoint) {
  const Triangle b = Tri({4, 0, 0}, {5, 1, 1}, {6, -1, 2});
  const TriangleIntersection r = IntersectTriangles(kBase, b);
  ASSERT_TRUE(r.intersect);
  EXPECT_EQ(r.p0, Vector3(4, 0, 0));
  EXPECT_EQ(r.p1, Vector3(4, 0, 0));
}

TEST(TriangleTriangle, VertexOnFaceTouchesAtTheVertex) {
  const Triangle b = Tri({1, 1, 0}, {1, 2, 3}, {3, 1, 2});
  const TriangleIntersection r = IntersectTriangles(kBase, b);
  ASSERT_TRUE(r.intersect);
  EXPECT_EQ(r.p0, Vector3(1, 1, 0));
  EXPECT_EQ(r.p1, Vector3(1, 1, 0));
  // lifted by one ulp-sized dyadic step, it misses
  const Vector3 up(0, 0, std::ldexp(1.0, -40));
  EXPECT_FALSE(TrianglesIntersect(kBase, Tri(b.v0 + up, b.v1 + up, b.v2 + up)));
}

TEST(TriangleTriangle, SkewEdgesTouchingAtOnePoint) {
  // b's edge (2,-1,1)-(2,1,-1) crosses a's edge y = 0 at (2,0,0); b leans away
  const Triangle b = Tri({2, -1, 1}, {2, 1, -1}, {3, -1, -1});
  ASSERT_LT(Orient3d(kBase.v0, kBase.v1, kBase.v2, b.v2) *
                Orient3d(kBase.v0, kBase.v1, kBase.v2, b.v0),
            0);
  const TriangleIntersection r = IntersectTriangles(kBase, b);
  ASSERT_TRUE(r.intersect);
  EXPECT_EQ(r.p0, r.p1);
  EXPECT_NEAR((r.p0 - Vector3(2, 0, 0)).norm(), 0, 1e-15);
  const Vector3 shift(0, -std::ldexp(1.0, -40), 0);
  EXPECT_FALSE(TrianglesIntersect(kBase, Tri(b.v0 + shift, b.v1 + shift, b.v2 + shift)));
}

TEST(TriangleTriangle, EdgeLyingOnTheFaceIsTheSegment) {
  const Triangle b = Tri({1, 1, 0}, {2, 1, 0}, {1, 2, 3});
  const TriangleIntersection r = IntersectTriangles(kBase, b);
  ASSERT_TRUE(r.intersect);
  EXPECT_FALSE(r.coplanar);
  const Vector3 lo(1, 1, 0), hi(2, 1, 0);
  EXPECT_TRUE((r.p0 == lo && r.p1 == hi) || (r.p0 == hi && r.p1 == lo));
}

TEST(TriangleTriangle, HingeOfCollinearEdges) {
  // b stands on a's edge y = 0, sharing the part x in [1, 3]
  const Triangle b = Tri({1, 0, 0}, {3, 0, 0}, {2, 0, 3});
  const TriangleIntersection r = IntersectTriangles(kBase, b);
  ASSERT_TRUE(r.intersect);
  const Vector3 lo(1, 0, 0), hi(3, 0, 0);
  EXPECT_TRUE((r.p0 == lo && r.p1 == hi) || (r.p0 == hi && r.p1 == lo));
  // collinear edges that only share an endpoint
  const TriangleIntersection end = IntersectTriangles(kBase, Tri({4, 0, 0}, {6, 0, 0}, {5, 0, 3}));
  ASSERT_TRUE(end.intersect);
  EXPECT_EQ(end.p0, Vector3(4, 0, 0));
  EXPECT_EQ(end.p1, Vector3(4, 0, 0));
  // and collinear edges with a gap
  EXPECT_FALSE(TrianglesIntersect(kBase, Tri({4.25, 0, 0}, {6, 0, 0}, {5, 0, 3})));
}

TEST(TriangleTriangle, CoplanarCases) {
  const double tiny = std::ldexp(1.0, -40);
  // overlapping
  TriangleIntersection r = IntersectTriangles(kBase, Tri({1, 1, 0}, {5, 1, 0}, {1, 5, 0}));
  EXPECT_TRUE(r.intersect);
  EXPECT_TRUE(r.coplanar);
  // one inside the other (no edges cross)
  EXPECT_TRUE(TrianglesIntersect(kBase, Tri({1, 1, 0}, {2, 1, 0}, {1, 2, 0})));
  EXPECT_TRUE(TrianglesIntersect(Tri({1, 1, 0}, {2, 1, 0}, {1, 2, 0}), kBase));
  // sharing part of an edge, lying on opposite sides of it
  EXPECT_TRUE(TrianglesIntersect(kBase, Tri({1, 0, 0}, {3, 0, 0}, {2, -2, 0})));
  // touching at a vertex on the other's edge
  EXPECT_TRUE(TrianglesIntersect(kBase, Tri({2, 2, 0}, {4, 4, 0}, {2, 5, 0})));
  // touching vertex to vertex
  EXPECT_TRUE(TrianglesIntersect(kBase, Tri({4, 0, 0}, {6, 0, 0}, {5, 1, 0})));
  // a tiny gap
  EXPECT_FALSE(TrianglesIntersect(kBase, Tri({2 + tiny, 2 + tiny, 0}, {4, 4, 0}, {2, 5, 0})));
  EXPECT_FALSE(TrianglesIntersect(kBase, Tri({4 + tiny, 0, 0}, {6, 0, 0}, {5, 1, 0})));
  // separated by a line that is no edge direction of a (only b's edge separates)
  EXPECT_FALSE(TrianglesIntersect(kBase, Tri({3, 3, 0}, {2.5, 4, 0}, {10, 10, 0})));
  // a tilted common plane (x + y + z = 1, scaled) with a shared edge
  const Triangle t1 = Tri({1, 0, 0}, {0, 1, 0}, {0, 0, 1});
  const Triangle t2 = Tri({1, 0, 0}, {0, 1, 0}, {1, 1, -1});
  r = IntersectTriangles(t1, t2);
  EXPECT_TRUE(r.intersect);
  EXPECT_TRUE(r.coplanar);
  EXPECT_FALSE(TrianglesIntersect(t1, Tri({1 + tiny, 0.5, -0.5 - tiny}, {1, 1, -1}, {2, 0, -1})));
}

TEST(TriangleTriangle, NonFiniteInputNeitherCrashesNorIntersects) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const Triangle b = Tri({1, 1, -2}, {1, 1, 2}, {3, 1, 0});
  for (double bad : {nan, inf, -inf}) {
    for (int i = 0; i < 9; ++i) {
      Triangle t = b;
      Vector3* v[] = {&t.v0, &t.v1, &t.v2};
      (*v[i / 3])[i % 3] = bad;
      EXPECT_FALSE(TrianglesIntersect(kBase, t));
      EXPECT_FALSE(IntersectTriangles(t, kBase).intersect);
    }
  }
}

// ---------------------------------------------------------------------------------
// Random cases against the exact oracle.

TEST(TriangleTriangle, MatchesExactOracleOnIntegerGrid) {
  std::mt19937_64 rng(20240601);
  int intersecting = 0, coplanar = 0, touching_point = 0;
  const int kCases = 30000;
  for (int n = 0; n < kCases; ++n) {
    const ITri ia = RandomITri(rng, 4);
    const ITri ib = RandomITriNear(rng, ia, 4);
    const bool expected = OracleIntersect(ia, ib);
    // an exact change of scale and origin changes nothing
    const double scale = std::ldexp(1.0, static_cast<int>(rng() % 40) - 20);
    const Vector3 offset = Vector3(static_cast<double>(rng() % 1024) - 512, 3, -7) * scale;
    const Triangle a = ToTriangle(ia, scale, offset);
    const Triangle b = ToTriangle(ib, scale, offset);
    intersecting += expected;
    coplanar += OracleCoplanar(ia, ib);

    const TriangleIntersection r = IntersectTriangles(a, b);
    ASSERT_EQ(r.intersect, expected) << "case " << n;
    ASSERT_EQ(TrianglesIntersect(a, b), expected) << "case " << n;
    if (expected) {
      ASSERT_EQ(r.coplanar, OracleCoplanar(ia, ib)) << "case " << n;
    }
    // every vertex order of either triangle, and either argument order
    for (const Triangle& pa : Orders(a)) {
      for (const Triangle& pb : Orders(b)) {
        ASSERT_EQ(TrianglesIntersect(pa, pb), expected) << "case " << n;
        ASSERT_EQ(TrianglesIntersect(pb, pa), expected) << "case " << n;
      }
    }
    // the segment: bounded by, and containing, the oracle's boundary points
    if (expected && !r.coplanar) {
      const std::vector<Vector3> points = OracleBoundaryPoints(ia, ib, scale);
      std::vector<Vector3> shifted;
      for (const Vector3& p : points) shifted.push_back(p + offset);
      const double tol = 1e-13 * scale * 16 + 1e-15 * offset.norm();
      ExpectSegmentMatches(r, shifted, tol, ("grid case " + std::to_string(n)).c_str());
      touching_point += r.p0 == r.p1;
      for (const Vector3& end : {r.p0, r.p1}) {
        EXPECT_LE(DistanceToTriangle(end, a), tol);
        EXPECT_LE(DistanceToTriangle(end, b), tol);
      }
    }
  }
  // the generator must exercise every kind of case
  EXPECT_GT(intersecting, kCases / 5);
  EXPECT_GT(kCases - intersecting, kCases / 5);
  EXPECT_GT(coplanar, kCases / 50);
  EXPECT_GT(touching_point, kCases / 100);
}

// Real-valued triangles: the oracle is that non-coplanar triangles intersect iff an
// edge of one crosses the other (watertight segment-triangle), and the segment's ends
// are the extreme crossing points.
TEST(TriangleTriangle, MatchesEdgeCrossingOracleOnRandomTriangles) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1, 1);
  int hits = 0;
  const int kCases = 40000;
  for (int n = 0; n < kCases; ++n) {
    const double spread = n % 2 ? 1.0 : 1e-3;
    const Vector3 center(unit(rng) * 100, unit(rng) * 100, unit(rng) * 100);
    auto random_point = [&] {
      return Vector3(center + spread * Vector3(unit(rng), unit(rng), unit(rng)));
    };
    const Triangle a = Tri(random_point(), random_point(), random_point());
    const Triangle b = Tri(random_point() + 0.5 * spread * Vector3(unit(rng), 0, 0),
                           random_point(), random_point());
    std::vector<Vector3> crossings;
    const auto add_crossings = [&](const Triangle& x, const Triangle& y) {
      const Vector3 c[] = {x.v0, x.v1, x.v2};
      for (int i = 0; i < 3; ++i) {
        const TriangleHit h = IntersectSegmentTriangleWatertight(c[i], c[(i + 1) % 3], y);
        if (h.hit) crossings.push_back(c[i] + h.t * (c[(i + 1) % 3] - c[i]));
      }
    };
    add_crossings(a, b);
    add_crossings(b, a);
    const bool expected = !crossings.empty();
    const TriangleIntersection r = IntersectTriangles(a, b);
    ASSERT_EQ(r.intersect, expected) << "case " << n;
    ASSERT_EQ(TrianglesIntersect(b, a), expected) << "case " << n;
    if (!expected) continue;
    ++hits;
    ASSERT_FALSE(r.coplanar);
    const double tol = 1e-9 * spread;
    ExpectSegmentMatches(r, crossings, tol, ("random case " + std::to_string(n)).c_str());
    // swapping the arguments gives the same segment (ends in either order)
    const TriangleIntersection s = IntersectTriangles(b, a);
    const double same = std::max((s.p0 - r.p0).norm(), (s.p1 - r.p1).norm());
    const double crossed = std::max((s.p0 - r.p1).norm(), (s.p1 - r.p0).norm());
    EXPECT_LE(std::min(same, crossed), tol) << "case " << n;
  }
  EXPECT_GT(hits, kCases / 10);
  EXPECT_GT(kCases - hits, kCases / 10);
}

// Touching by construction, at generic (many-bit) dyadic coordinates: a vertex of b
// placed exactly on a's face, edge or vertex, with b's other vertices on one side.
TEST(TriangleTriangle, ConstructedTouchingAtGenericCoordinates) {
  std::mt19937_64 rng(99);
  std::uniform_int_distribution<int64_t> bits(-(int64_t{1} << 24), int64_t{1} << 24);
  const auto dyadic = [&] {
    return Vector3(std::ldexp(bits(rng), -24), std::ldexp(bits(rng), -24),
                   std::ldexp(bits(rng), -24));
  };
  int tested = 0;
  for (int n = 0; n < 20000; ++n) {
    const Triangle a = Tri(dyadic(), dyadic(), dyadic());
    if (IsDegenerateTriangle(a.v0, a.v1, a.v2)) continue;
    // the touching point: barycentric weights with few bits keep it exact
    const int w1 = static_cast<int>(rng() % 5), w2 = static_cast<int>(rng() % (5 - w1));
    const Vector3 x = a.v0 + (w1 * (a.v1 - a.v0) + w2 * (a.v2 - a.v0)) / 4.0;
    if (Orient3d(a.v0, a.v1, a.v2, x) != 0) continue;  // the construction rounded
    const Vector3 q = dyadic(), r = dyadic();
    const int sq = Orient3d(a.v0, a.v1, a.v2, q), sr = Orient3d(a.v0, a.v1, a.v2, r);
    if (sq == 0 || sq != sr || IsDegenerateTriangle(x, q, r)) continue;
    const Triangle b = Tri(x, q, r);
    ++tested;
    const TriangleIntersection hit = IntersectTriangles(a, b);
    ASSERT_TRUE(hit.intersect) << "case " << n;
    EXPECT_EQ(hit.p0, x);
    EXPECT_EQ(hit.p1, x);
    for (const Triangle& pa : Orders(a)) {
      for (const Triangle& pb : Orders(b)) ASSERT_TRUE(TrianglesIntersect(pb, pa));
    }
    // moved off a's plane by a tiny exact step, on the side of q and r, it misses
    const Vector3 n_a = (a.v1 - a.v0).cross(a.v2 - a.v0);
    int axis;
    n_a.cwiseAbs().maxCoeff(&axis);
    Vector3 step = Vector3::Zero();
    step[axis] = std::ldexp(1.0, -40) * (n_a[axis] > 0 ? sq : -sq);
    EXPECT_FALSE(TrianglesIntersect(a, Tri(x + step, q + step, r + step))) << "case " << n;
  }
  EXPECT_GT(tested, 2000);
}

}  // namespace
}  // namespace hapticd::geometry
