#include "server/geometry/convex_hull.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <set>

#include "server/geometry/exact_predicates.h"
#include "server/geometry/gjk.h"
#include "server/geometry/test/random_geometry.h"

namespace hapticd::geometry {
namespace {

// Volume by the divergence theorem; positive when the faces wind outward.
double Volume(const ConvexHull& h) {
  double six_v = 0;
  for (const auto& f : h.faces) six_v += h.vertices[f[0]].dot(h.vertices[f[1]].cross(h.vertices[f[2]]));
  return six_v / 6;
}

// The invariants that make a 3D hull the hull of points: a closed, outward, convex
// triangle surface (every edge between two faces that wind it oppositely, Euler's
// formula, every vertex on or behind every face, exactly), whose vertices are input
// points, with every input point on or behind every face (exactly). Together they say
// hull == conv(points).
void ExpectValidPolyhedron(const ConvexHull& h, const std::vector<Vector3>& points) {
  ASSERT_EQ(h.dimension, 3);
  const int v = h.num_vertices(), e = static_cast<int>(h.edges.size()), f = static_cast<int>(h.faces.size());
  EXPECT_EQ(v - e + f, 2);
  EXPECT_EQ(2 * e, 3 * f);
  ASSERT_EQ(h.edge_faces.size(), h.edges.size());
  for (size_t k = 0; k < h.edges.size(); ++k) {
    const auto [i, j] = h.edges[k];
    EXPECT_LT(i, j);
    const auto& f0 = h.faces[h.edge_faces[k][0]];
    const auto& f1 = h.faces[h.edge_faces[k][1]];
    bool forward = false, backward = false;
    for (int m = 0; m < 3; ++m) {
      forward = forward || (f0[m] == i && f0[(m + 1) % 3] == j);
      backward = backward || (f1[m] == j && f1[(m + 1) % 3] == i);
    }
    EXPECT_TRUE(forward && backward) << "edge " << k;
  }
  for (int i = 0; i < v; ++i) {
    ASSERT_GE(h.input_index[i], 0);
    EXPECT_EQ(h.vertices[i], points[h.input_index[i]]);
  }
  for (const auto& face : h.faces) {
    EXPECT_FALSE(IsDegenerateTriangle(h.vertices[face[0]], h.vertices[face[1]], h.vertices[face[2]]));
    for (const Vector3& p : points) {
      ASSERT_LE(Orient3d(h.vertices[face[0]], h.vertices[face[1]], h.vertices[face[2]], p), 0);
    }
  }
  // adjacency is the edge list, symmetric
  std::set<std::pair<int, int>> edges;
  for (const auto& ed : h.edges) edges.insert({ed[0], ed[1]});
  EXPECT_EQ(edges.size(), h.edges.size());
  for (int i = 0; i < v; ++i) {
    for (int j : h.neighbors(i)) EXPECT_TRUE(edges.count({std::min(i, j), std::max(i, j)}));
  }
  EXPECT_GT(Volume(h), 0);
}

TEST(ConvexHull, CubeWithInteriorAndSurfacePoints) {
  std::vector<Vector3> points;
  for (int i = 0; i < 8; ++i) points.push_back(Vector3(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1));
  // face centres, edge midpoints and interior points: none may change the hull
  for (int k = 0; k < 3; ++k) points.push_back(Vector3::Unit(k)), points.push_back(-Vector3::Unit(k));
  points.push_back(Vector3(1, 1, 0));
  points.push_back(Vector3(0, -1, 1));
  points.push_back(Vector3(0.25, 0.5, -0.125));
  points.push_back(Vector3::Zero());
  const ConvexHull h = BuildConvexHull(points);
  ExpectValidPolyhedron(h, points);
  EXPECT_DOUBLE_EQ(Volume(h), 8.0);
  // every corner is a vertex
  std::set<int> inputs(h.input_index.begin(), h.input_index.end());
  for (int i = 0; i < 8; ++i) EXPECT_TRUE(inputs.count(i)) << i;
  // unit outward normals: along the axes for a cube
  for (size_t f = 0; f < h.faces.size(); ++f) {
    EXPECT_NEAR(h.face_normals[f].norm(), 1, 1e-15);
    EXPECT_NEAR(h.face_normals[f].cwiseAbs().maxCoeff(), 1, 1e-15);
    EXPECT_NEAR(h.face_normals[f].dot(h.vertices[h.faces[f][0]]), 1, 1e-15);
  }
}

TEST(ConvexHull, IntegerGridHasManyCoplanarAndCollinearPoints) {
  std::vector<Vector3> points;
  for (int x = 0; x < 4; ++x) {
    for (int y = 0; y < 4; ++y) {
      for (int z = 0; z < 4; ++z) points.push_back(Vector3(x, y, z));
    }
  }
  std::shuffle(points.begin(), points.end(), std::mt19937_64(3));
  const ConvexHull h = BuildConvexHull(points);
  ExpectValidPolyhedron(h, points);
  EXPECT_DOUBLE_EQ(Volume(h), 27.0);
}

TEST(ConvexHull, RandomCloudsSatisfyTheInvariants) {
  std::mt19937_64 rng(1);
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 4 + trial % 60;
    std::vector<Vector3> points = RandomBall(rng, n, 1.0);
    // duplicates must not matter
    points.push_back(points[0]);
    const ConvexHull h = BuildConvexHull(points);
    ExpectValidPolyhedron(h, points);
    if (testing::Test::HasFailure()) return;
  }
}

TEST(ConvexHull, PointsOnASphereAreAllVertices) {
  std::mt19937_64 rng(2);
  std::normal_distribution<double> g(0, 1);
  std::vector<Vector3> points;
  for (int i = 0; i < 300; ++i) points.push_back(Vector3(g(rng), g(rng), g(rng)).normalized());
  const ConvexHull h = BuildConvexHull(points);
  ExpectValidPolyhedron(h, points);
  EXPECT_EQ(h.num_vertices(), 300);
}

TEST(ConvexHull, HillClimbingSupportMatchesBruteForce) {
  std::mt19937_64 rng(4);
  std::normal_distribution<double> g(0, 1);
  const std::vector<Vector3> points = RandomBall(rng, 200, 2.0);
  const ConvexHull h = BuildConvexHull(points);
  const HullSupport climb(h);
  const PointSetSupport brute(points);
  int hint = -1;
  for (int i = 0; i < 500; ++i) {
    const Vector3 d(g(rng), g(rng), g(rng));
    const SupportPoint s = climb.Support(d, hint, nullptr);
    hint = s.vertex;
    EXPECT_EQ(d.dot(s.point), d.dot(brute.Support(d, -1, nullptr).point));
  }
}

TEST(ConvexHull, AllPointsEqualGiveOneVertex) {
  const std::vector<Vector3> points(5, Vector3(0.5, -2, 3));
  const ConvexHull h = BuildConvexHull(points);
  EXPECT_EQ(h.dimension, 0);
  ASSERT_EQ(h.num_vertices(), 1);
  EXPECT_EQ(h.vertices[0], points[0]);
  EXPECT_TRUE(h.edges.empty());
  EXPECT_TRUE(h.faces.empty());
  EXPECT_TRUE(h.neighbors(0).empty());
}

TEST(ConvexHull, CollinearPointsGiveTheExtremeSegment) {
  // exactly collinear: p = (1, 2, 3) + t (0.5, -0.25, 2) with dyadic t
  std::vector<Vector3> points;
  for (double t : {0.5, -1.0, 3.0, 0.5, 2.0, -0.75}) points.push_back(Vector3(1, 2, 3) + t * Vector3(0.5, -0.25, 2));
  const ConvexHull h = BuildConvexHull(points);
  EXPECT_EQ(h.dimension, 1);
  ASSERT_EQ(h.num_vertices(), 2);
  const std::set<int> ends(h.input_index.begin(), h.input_index.end());
  EXPECT_EQ(ends, (std::set<int>{1, 2}));
  ASSERT_EQ(h.edges.size(), 1u);
  EXPECT_NEAR(std::abs(h.axis.dot(Vector3(0.5, -0.25, 2).normalized())), 1, 1e-15);
}

TEST(ConvexHull, CoplanarPointsGiveAConvexPolygon) {
  std::mt19937_64 rng(5);
  std::uniform_int_distribution<int> coord(-50, 50);
  // exactly coplanar: z = x + 2y - 3 on integers
  std::vector<Vector3> points;
  for (int i = 0; i < 80; ++i) {
    const double x = coord(rng), y = coord(rng);
    points.push_back(Vector3(x, y, x + 2 * y - 3));
  }
  const ConvexHull h = BuildConvexHull(points);
  ASSERT_EQ(h.dimension, 2);
  const int m = h.num_vertices();
  ASSERT_GE(m, 3);
  EXPECT_EQ(h.faces.size(), static_cast<size_t>(m - 2));
  EXPECT_EQ(h.edges.size(), static_cast<size_t>(m));
  // the plane normal, counter-clockwise winding, strict convexity, all points inside
  EXPECT_NEAR(std::abs(h.axis.dot(Vector3(1, 2, -1).normalized())), 1, 1e-14);
  const auto& v = h.vertices;
  for (int i = 0; i < m; ++i) {
    const Vector3 turn = (v[(i + 1) % m] - v[i]).cross(v[(i + 2) % m] - v[(i + 1) % m]);
    EXPECT_GT(turn.dot(h.axis), 0);
    for (const Vector3& p : points) EXPECT_GE((v[(i + 1) % m] - v[i]).cross(p - v[i]).dot(h.axis), 0);
  }
  for (int i = 0; i < m; ++i) EXPECT_EQ(h.neighbors(i).size(), 2u);
}

TEST(ConvexHull, EmptyAndNonFiniteInputGiveNoHull) {
  EXPECT_EQ(BuildConvexHull({}).dimension, -1);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<Vector3> points = {Vector3(0, 0, 0), Vector3(1, 0, 0), Vector3(0, 1, 0), Vector3(0, 0, 1)};
  points.push_back(Vector3(0.5, nan, 0));
  EXPECT_EQ(BuildConvexHull(points).dimension, -1);
  points.back() = Vector3(inf, 0, 0);
  EXPECT_EQ(BuildConvexHull(points).dimension, -1);
  EXPECT_EQ(BuildConvexHull(points).num_vertices(), 0);
}

TEST(ValidatePointSet, NamesTheBadPoint) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<Vector3> points = {Vector3(0, 0, 0), Vector3(1, 2, 3), Vector3(-0.5, nan, 0.25)};
  const auto message = ValidatePointSet(points, "a");
  ASSERT_TRUE(message.has_value());
  EXPECT_EQ(*message, "point 2 of set a is (-0.5, nan, 0.25): coordinates must be finite");
  points[2] = Vector3(0, 0, -std::numeric_limits<double>::infinity());
  EXPECT_EQ(*ValidatePointSet(points, "b"), "point 2 of set b is (0, 0, -inf): coordinates must be finite");
  points[2] = Vector3(0, 1e200, 0);
  EXPECT_EQ(*ValidatePointSet(points, "b"),
            "point 2 of set b is (0, 1e+200, 0): a coordinate exceeds 1e100 in magnitude");
  EXPECT_EQ(*ValidatePointSet({}, "b"), "point set b is empty");
  points.pop_back();
  EXPECT_FALSE(ValidatePointSet(points, "a").has_value());
}

}  // namespace
}  // namespace hapticd::geometry
