#include "server/geometry/triangle_mesh.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "server/geometry/mesh_generators.h"

namespace hapticd::geometry {
namespace {

using Indices = TriangleMesh::TriangleIndices;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// A tetrahedron with outward (counter-clockwise seen from outside) faces.
const std::vector<Vector3> kTetraVertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
const std::vector<Indices> kTetraTriangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};

// The message of the std::invalid_argument that creating the mesh throws ("" if none).
std::string CreationError(std::vector<Vector3> vertices, std::vector<Indices> triangles) {
  try {
    TriangleMesh mesh(std::move(vertices), std::move(triangles));
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// ---------------------------------------------------------------------------------
// Validation: each rejection names the bad value.

TEST(TriangleMesh, RejectsNonFiniteVertexNamingIt) {
  auto vertices = kTetraVertices;
  vertices[1] = {kNan, 0, 1};
  EXPECT_EQ(CreationError(vertices, kTetraTriangles),
            "vertex 1 has a non-finite coordinate: [nan, 0, 1]");
  vertices[1] = {0.5, -kInf, 1};
  EXPECT_EQ(CreationError(vertices, kTetraTriangles),
            "vertex 1 has a non-finite coordinate: [0.5, -inf, 1]");
  // a non-finite vertex no triangle uses is still rejected
  vertices = kTetraVertices;
  vertices.push_back({0, kInf, 0});
  EXPECT_EQ(CreationError(vertices, kTetraTriangles),
            "vertex 4 has a non-finite coordinate: [0, inf, 0]");
}

TEST(TriangleMesh, RejectsIndexOutOfRangeNamingIt) {
  auto triangles = kTetraTriangles;
  triangles[3] = {1, 2, 57};
  EXPECT_EQ(CreationError(kTetraVertices, triangles),
            "triangle 3 refers to vertex 57 but the mesh has 4 vertices");
  triangles[3] = {1, 4, 3};
  EXPECT_EQ(CreationError(kTetraVertices, triangles),
            "triangle 3 refers to vertex 4 but the mesh has 4 vertices");
  triangles[3] = {-1, 2, 3};
  EXPECT_EQ(CreationError(kTetraVertices, triangles),
            "triangle 3 refers to vertex -1 but the mesh has 4 vertices");
}

TEST(TriangleMesh, RejectsEmptyMesh) {
  EXPECT_EQ(CreationError({}, {}), "mesh is empty: it has 0 vertices and 0 triangles");
  EXPECT_EQ(CreationError(kTetraVertices, {}), "mesh is empty: it has 4 vertices and 0 triangles");
  EXPECT_EQ(CreationError({}, kTetraTriangles), "mesh is empty: it has 0 vertices and 4 triangles");
}

TEST(TriangleMesh, RejectsMeshWithOnlyDegenerateTriangles) {
  // collinear corners, a repeated index, and coincident positions
  const std::vector<Vector3> vertices = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {0, 0, 0}};
  EXPECT_EQ(CreationError(vertices, {{0, 1, 2}, {0, 0, 1}, {0, 3, 1}}),
            "mesh has no triangle of non-zero area: all 3 triangles are degenerate "
            "(collinear or coincident corners)");
}

TEST(TriangleMesh, AcceptsUnusedVertices) {
  auto vertices = kTetraVertices;
  vertices.push_back({100, 100, 100});
  const TriangleMesh mesh(vertices, kTetraTriangles);
  EXPECT_EQ(mesh.num_vertices(), 5);
  EXPECT_TRUE(mesh.is_closed());
  // bounds cover the triangles, not the stray vertex
  EXPECT_EQ(mesh.bounds().max, Vector3(1, 1, 1));
  EXPECT_EQ(mesh.vertex_pseudo_normal(4), Vector3::Zero());
}

// ---------------------------------------------------------------------------------
// Degenerate triangles are kept in place (indices stay the caller's) but dropped from
// everything derived.

TEST(TriangleMesh, DropsDegenerateTrianglesAndKeepsOriginalIndices) {
  auto vertices = kTetraVertices;
  vertices.push_back({0.5, 0.5, 0});  // on the edge 1-2, in the plane z = 0
  const std::vector<Indices> triangles = {
      {1, 4, 2},  // 0: collinear (zero area)
      kTetraTriangles[0], kTetraTriangles[1],
      {3, 3, 0},  // 3: repeated index
      kTetraTriangles[2], kTetraTriangles[3],
  };
  const TriangleMesh mesh(vertices, triangles);
  EXPECT_EQ(mesh.num_triangles(), 6);
  EXPECT_EQ(mesh.num_degenerate_triangles(), 2);
  EXPECT_EQ(mesh.nondegenerate_triangles(), (std::vector<int>{1, 2, 4, 5}));
  EXPECT_TRUE(mesh.is_degenerate(0));
  EXPECT_TRUE(mesh.is_degenerate(3));
  EXPECT_FALSE(mesh.is_degenerate(1));
  EXPECT_EQ(mesh.face_normal(0), Vector3::Zero());
  // the tetrahedron is still closed: the degenerate triangles' edges do not count
  EXPECT_TRUE(mesh.is_closed());
  EXPECT_DOUBLE_EQ(mesh.signed_volume(), 1.0 / 6);
  // triangle() addresses original indices
  EXPECT_EQ(mesh.triangle(5).v2, kTetraVertices[3]);
  EXPECT_EQ(mesh.face_normal(1), Vector3(0, 0, -1));
}

// A triangle of non-zero area whose normal underflows (edges of 1e-80 m: the cross
// product's squared length is subnormal) counts as zero-area: every query divides by
// that length. One of 1e-70 m still has a normal, and stays. (A fuzz find: a sweep
// onto such a triangle reported a zero normal.)
TEST(TriangleMesh, DropsTrianglesTooSmallForANormal) {
  for (const double edge : {1e-80, 1e-70}) {
    std::vector<Vector3> vertices = kTetraVertices;
    // near the origin, where edges this short are representable
    vertices.push_back({-edge, -edge, -edge});
    vertices.push_back({0, -edge, -edge});
    vertices.push_back({-edge, 0, -edge});
    std::vector<Indices> triangles = kTetraTriangles;
    triangles.push_back({4, 5, 6});
    const TriangleMesh mesh(vertices, triangles);
    const bool dropped = edge < 1e-77;
    EXPECT_EQ(mesh.is_degenerate(4), dropped) << edge;
    EXPECT_EQ(mesh.num_degenerate_triangles(), dropped ? 1 : 0) << edge;
    if (!dropped) {
      EXPECT_EQ(mesh.face_normal(4), Vector3(0, 0, 1)) << edge;
    }
  }
}

// ---------------------------------------------------------------------------------
// Open and closed.

// Repeats of an earlier triangle (the same three corner positions in any order or
// winding, through any vertex indices) are dropped like zero-area ones and counted; the
// first of each kind stays, so the mesh is the tetrahedron again.
TEST(TriangleMesh, DropsRepeatedTrianglesKeepingTheFirst) {
  auto vertices = kTetraVertices;
  vertices.push_back(vertices[1]);  // vertex 4 sits where vertex 1 does
  std::vector<Indices> triangles = kTetraTriangles;
  triangles.push_back({2, 1, 0});  // 4: face 0 with its winding reversed
  triangles.push_back({3, 0, 1});  // 5: face 1, corners rotated
  triangles.push_back({0, 4, 3});  // 6: face 1 through the twin of vertex 1
  triangles.push_back({1, 2, 3});  // 7: face 3 again, index for index
  triangles.push_back({0, 0, 1});  // 8: zero area
  const TriangleMesh mesh(vertices, triangles);
  EXPECT_EQ(mesh.num_triangles(), 9);
  EXPECT_EQ(mesh.num_repeated_triangles(), 4);
  EXPECT_EQ(mesh.num_degenerate_triangles(), 5);
  EXPECT_EQ(mesh.nondegenerate_triangles(), (std::vector<int>{0, 1, 2, 3}));
  for (int t : {4, 5, 6, 7, 8}) EXPECT_TRUE(mesh.is_degenerate(t)) << t;
  // without the repeats every edge is shared twice, oppositely: closed, volume 1/6
  EXPECT_TRUE(mesh.is_closed());
  EXPECT_NEAR(mesh.signed_volume(), 1.0 / 6, 1e-15);
  EXPECT_EQ(mesh.face_normal(4), Vector3::Zero());
}

// Nearly equal is not equal: a triangle one ulp away from another is a triangle.
TEST(TriangleMesh, KeepsTrianglesThatDifferByAnUlp) {
  auto vertices = kTetraVertices;
  vertices.push_back({std::nextafter(1.0, 2.0), 0, 0});
  std::vector<Indices> triangles = kTetraTriangles;
  triangles.push_back({0, 4, 3});
  const TriangleMesh mesh(vertices, triangles);
  EXPECT_EQ(mesh.num_repeated_triangles(), 0);
  EXPECT_EQ(mesh.nondegenerate_triangles().size(), 5u);
}

TEST(TriangleMesh, TetrahedronIsClosedAndOutward) {
  const TriangleMesh mesh(kTetraVertices, kTetraTriangles);
  EXPECT_TRUE(mesh.is_closed());
  EXPECT_DOUBLE_EQ(mesh.signed_volume(), 1.0 / 6);
}

TEST(TriangleMesh, MissingTriangleMakesItOpen) {
  auto triangles = kTetraTriangles;
  triangles.pop_back();
  EXPECT_FALSE(TriangleMesh(kTetraVertices, triangles).is_closed());
}

TEST(TriangleMesh, InconsistentOrientationIsRewound) {
  // every edge still has two triangles, but one triangle runs its edges the same way
  // as its neighbours: it alone is turned back
  auto triangles = kTetraTriangles;
  std::swap(triangles[2][1], triangles[2][2]);
  const TriangleMesh mesh(kTetraVertices, triangles);
  EXPECT_TRUE(mesh.is_closed());
  EXPECT_EQ(mesh.closure(), MeshClosure::kClosed);
  EXPECT_EQ(mesh.num_rewound_triangles(), 1);
  EXPECT_EQ(mesh.triangles(), kTetraTriangles);
  EXPECT_DOUBLE_EQ(mesh.signed_volume(), 1.0 / 6);
  EXPECT_EQ(mesh.face_normal(2), Vector3(-1, 0, 0));
}

TEST(TriangleMesh, InsideOutIsRewoundOutwards) {
  auto triangles = kTetraTriangles;
  for (Indices& t : triangles) std::swap(t[1], t[2]);
  const TriangleMesh mesh(kTetraVertices, triangles);
  EXPECT_TRUE(mesh.is_closed());
  EXPECT_EQ(mesh.num_rewound_triangles(), 4);
  EXPECT_EQ(mesh.triangles(), kTetraTriangles);
  EXPECT_DOUBLE_EQ(mesh.signed_volume(), 1.0 / 6);
  EXPECT_EQ(mesh.face_normal(0), Vector3(0, 0, -1));
  // the pseudo-normals follow: the corner at the origin looks away from the solid
  EXPECT_LT(mesh.vertex_pseudo_normal(0).dot(Vector3::Ones()), 0);
}

TEST(TriangleMesh, OpenMeshesAreKeptAsGiven) {
  auto triangles = kTetraTriangles;
  triangles.pop_back();
  std::swap(triangles[0][1], triangles[0][2]);
  const TriangleMesh mesh(kTetraVertices, triangles);
  EXPECT_EQ(mesh.closure(), MeshClosure::kOpen);
  EXPECT_EQ(mesh.num_rewound_triangles(), 0);
  EXPECT_EQ(mesh.triangles(), triangles);
}

// The 6-vertex real projective plane (the hemi-icosahedron): every edge has two
// triangles, but no winding agrees across all of them.
TEST(TriangleMesh, ProjectivePlaneIsNonOrientable) {
  const std::vector<Vector3> vertices = {{0, 0, 1.1}, {1, 0.1, 0}, {0.3, 1, 0.2},
                                         {-1, 0.2, -0.1}, {0.1, -1, 0.3}, {0.2, 0.3, -1}};
  const std::vector<Indices> triangles = {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 4, 5}, {0, 5, 1},
                                          {1, 2, 4}, {2, 3, 5}, {3, 4, 1}, {4, 5, 2}, {5, 1, 3}};
  const TriangleMesh mesh(vertices, triangles);
  EXPECT_EQ(mesh.closure(), MeshClosure::kNonOrientable);
  EXPECT_FALSE(mesh.is_closed());
  EXPECT_EQ(mesh.num_rewound_triangles(), 0);
  EXPECT_EQ(mesh.triangles(), triangles);
  EXPECT_EQ(MeshClosureName(mesh.closure()), "non-orientable");
}

// Two meshes in one: the triangles of b after those of a, b's indices shifted.
TriangleMesh Merge(const TriangleMesh& a, const TriangleMesh& b, bool reverse_a, bool reverse_b) {
  std::vector<Vector3> vertices = a.vertices();
  vertices.insert(vertices.end(), b.vertices().begin(), b.vertices().end());
  std::vector<Indices> triangles;
  for (Indices t : a.triangles()) {
    if (reverse_a) std::swap(t[1], t[2]);
    triangles.push_back(t);
  }
  for (Indices t : b.triangles()) {
    for (int& v : t) v += a.num_vertices();
    if (reverse_b) std::swap(t[1], t[2]);
    triangles.push_back(t);
  }
  return TriangleMesh(vertices, triangles);
}

// A shell inside another bounds a cavity: its normals must point into the cavity, away
// from the solid between the shells, whatever winding either shell was given.
TEST(TriangleMesh, ANestedShellIsACavity) {
  const TriangleMesh outer = MakeIcosphere(4, 1.0);
  const TriangleMesh inner = MakeIcosphere(3, 0.5);
  const double hollow = outer.signed_volume() - inner.signed_volume();
  for (bool reverse_outer : {false, true}) {
    for (bool reverse_inner : {false, true}) {
      const TriangleMesh mesh = Merge(outer, inner, reverse_outer, reverse_inner);
      EXPECT_TRUE(mesh.is_closed());
      // the inner shell comes out inward: reversed from the generator's winding
      const int expected = (reverse_outer ? outer.num_triangles() : 0) +
                           (reverse_inner ? 0 : inner.num_triangles());
      EXPECT_EQ(mesh.num_rewound_triangles(), expected) << reverse_outer << reverse_inner;
      EXPECT_NEAR(mesh.signed_volume(), hollow, 1e-12) << reverse_outer << reverse_inner;
    }
  }
  // side by side, each shell bounds its own body
  TriangleMesh apart_inner = MakeIcosphere(3, 0.5);
  std::vector<Vector3> moved = apart_inner.vertices();
  for (Vector3& v : moved) v.x() += 3;
  const TriangleMesh beside = Merge(outer, TriangleMesh(moved, apart_inner.triangles()), false, true);
  EXPECT_EQ(beside.num_rewound_triangles(), inner.num_triangles());
  EXPECT_NEAR(beside.signed_volume(), outer.signed_volume() + inner.signed_volume(), 1e-12);
}

// Past the nesting check's work bound (about 3e7 box tests and triangle visits) every
// shell is turned outwards and the mesh says it was not checked: here 600 small
// tetrahedra, given inside out, inside a sphere of 65k triangles.
TEST(TriangleMesh, TooManyNestedShellsAreEachTurnedOutwards) {
  const TriangleMesh sphere = MakeIcosphere(57, 10.0);
  std::vector<Vector3> vertices = sphere.vertices();
  std::vector<Indices> triangles = sphere.triangles();
  for (int i = 0; i < 600; ++i) {
    const int base = static_cast<int>(vertices.size());
    const Vector3 at(-5 + 0.4 * (i % 25), -5 + 0.4 * (i / 25), 0);
    for (const Vector3& v : kTetraVertices) vertices.push_back(at + 0.1 * v);
    for (Indices t : kTetraTriangles) triangles.push_back({base + t[0], base + t[2], base + t[1]});
  }
  const TriangleMesh mesh(vertices, triangles);
  EXPECT_TRUE(mesh.is_closed());
  EXPECT_EQ(mesh.num_shells(), 601);
  EXPECT_FALSE(mesh.nesting_checked());
  EXPECT_EQ(mesh.num_rewound_triangles(), 600 * 4);
  EXPECT_NEAR(mesh.signed_volume(), sphere.signed_volume() + 600 * (0.001 / 6), 1e-9);
  // a few shells are checked within the bound
  EXPECT_TRUE(Merge(sphere, MakeIcosphere(3, 0.5), false, false).nesting_checked());
}

// Against the generator's outward winding as oracle: closed meshes with random
// triangles flipped (and a random rigid placement) come back wound exactly as
// generated.
TEST(TriangleMesh, RandomlyFlippedClosedMeshesComeBackOutward) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(-1, 1);
  std::bernoulli_distribution coin(0.3);
  const std::vector<TriangleMesh> shapes = {MakeIcosphere(3, 0.7), MakeTorus(1.0, 0.3, 16, 8),
                                            MakeBoxMesh({0.5, 1, 2}, 3)};
  for (int trial = 0; trial < 60; ++trial) {
    const TriangleMesh& shape = shapes[trial % shapes.size()];
    const Eigen::Matrix3d R =
        Eigen::Quaterniond(unit(rng), unit(rng), unit(rng), unit(rng)).normalized().toRotationMatrix();
    const Vector3 offset(unit(rng), unit(rng), unit(rng));
    std::vector<Vector3> vertices;
    for (const Vector3& v : shape.vertices()) vertices.push_back(R * v + 5 * offset);
    std::vector<Indices> triangles = shape.triangles();
    int flipped = 0;
    for (Indices& t : triangles) {
      if (coin(rng)) std::swap(t[1], t[2]), ++flipped;
    }
    const TriangleMesh mesh(vertices, triangles);
    ASSERT_TRUE(mesh.is_closed()) << trial;
    EXPECT_EQ(mesh.num_rewound_triangles(), flipped) << trial;
    EXPECT_EQ(mesh.triangles(), shape.triangles()) << trial;
    EXPECT_GT(mesh.signed_volume(), 0) << trial;
  }
}

TEST(TriangleMesh, EdgeSharedByThreeTrianglesIsNotClosed) {
  auto vertices = kTetraVertices;
  vertices.push_back({1, 1, -1});
  auto triangles = kTetraTriangles;
  triangles.push_back({1, 2, 4});  // a fin on edge 1-2
  EXPECT_FALSE(TriangleMesh(vertices, triangles).is_closed());
}

TEST(TriangleMesh, GeneratedMeshesAreClosedWithTheRightVolume) {
  const TriangleMesh sphere = MakeIcosphere(8, 2.0);
  EXPECT_EQ(sphere.num_triangles(), 20 * 64);
  EXPECT_EQ(sphere.num_vertices(), 10 * 64 + 2);
  EXPECT_TRUE(sphere.is_closed());
  EXPECT_NEAR(sphere.signed_volume(), 4.0 / 3 * std::numbers::pi * 8, 0.05 * 8);
  EXPECT_LT(sphere.signed_volume(), 4.0 / 3 * std::numbers::pi * 8);  // inscribed

  const TriangleMesh torus = MakeTorus(2.0, 0.5, 48, 24);
  EXPECT_EQ(torus.num_triangles(), 2 * 48 * 24);
  EXPECT_TRUE(torus.is_closed());
  EXPECT_NEAR(torus.signed_volume(), 2 * std::numbers::pi * std::numbers::pi * 2.0 * 0.25,
              0.02 * 10);

  const TriangleMesh box = MakeBoxMesh({0.5, 1, 2}, 4);
  EXPECT_EQ(box.num_triangles(), 12 * 16);
  EXPECT_EQ(box.num_vertices(), 6 * 16 + 2);
  EXPECT_TRUE(box.is_closed());
  EXPECT_EQ(box.signed_volume(), 8.0 * 0.5 * 1 * 2);  // dyadic: exact
  EXPECT_EQ(box.bounds().min, Vector3(-0.5, -1, -2));
}

TEST(TriangleMesh, GeneratorsRejectBadParameters) {
  EXPECT_THROW(MakeIcosphere(0, 1), std::invalid_argument);
  EXPECT_THROW(MakeIcosphere(2, -1), std::invalid_argument);
  EXPECT_THROW(MakeTorus(1, 2, 8, 8), std::invalid_argument);
  EXPECT_THROW(MakeTorus(2, 1, 2, 8), std::invalid_argument);
  EXPECT_THROW(MakeBoxMesh({1, 0, 1}), std::invalid_argument);
  EXPECT_THROW(MakeBoxMesh({1, 1, 1}, 0), std::invalid_argument);
}

// ---------------------------------------------------------------------------------
// Pseudo-normals: angle weighting makes them independent of how faces are triangulated.

TEST(TriangleMesh, BoxPseudoNormalsAreTheSymmetricOnes) {
  // each box face is split into 2 triangles, so a corner sees one or two triangles
  // per face; only the angle weighting gives (1, 1, 1) / sqrt 3 at every corner
  const TriangleMesh box = MakeBoxMesh({1, 1, 1}, 1);
  for (int v = 0; v < box.num_vertices(); ++v) {
    const Vector3 expected = box.vertices()[v].normalized();
    EXPECT_LT((box.vertex_pseudo_normal(v) - expected).norm(), 1e-15) << "vertex " << v;
  }
  // edges along the box's edges average two faces; the diagonals inside a face keep it
  int box_edges = 0, diagonals = 0;
  for (int t = 0; t < box.num_triangles(); ++t) {
    const Indices& f = box.triangles()[t];
    for (int e = 0; e < 3; ++e) {
      const Vector3 a = box.vertices()[f[e]], b = box.vertices()[f[(e + 1) % 3]];
      const Vector3 mid = 0.5 * (a + b);
      const int zeros = (mid.array() == 0).count();
      if (zeros == 2) {
        ++diagonals;
        EXPECT_LT((box.edge_pseudo_normal(t, e) - box.face_normal(t)).norm(), 1e-15);
      } else {
        ++box_edges;
        EXPECT_LT((box.edge_pseudo_normal(t, e) - mid.normalized()).norm(), 1e-15);
      }
    }
  }
  EXPECT_EQ(box_edges, 24);  // 12 edges, seen from 2 triangles each
  EXPECT_EQ(diagonals, 12);
}

TEST(TriangleMesh, FeatureNormalPicksTheFeature) {
  const TriangleMesh mesh(kTetraVertices, kTetraTriangles);
  const int t = 3;  // {1, 2, 3}
  EXPECT_EQ(mesh.FeatureNormal(t, TriangleFeature::kFace), mesh.face_normal(t));
  EXPECT_EQ(mesh.FeatureNormal(t, TriangleFeature::kVertex0), mesh.vertex_pseudo_normal(1));
  EXPECT_EQ(mesh.FeatureNormal(t, TriangleFeature::kVertex2), mesh.vertex_pseudo_normal(3));
  EXPECT_EQ(mesh.FeatureNormal(t, TriangleFeature::kEdge12), mesh.edge_pseudo_normal(t, 1));
  EXPECT_EQ(mesh.FeatureNormal(t, TriangleFeature::kEdge20), mesh.edge_pseudo_normal(t, 2));
  // the slanted face's normal, and the edge it shares with face 0 (normal -z)
  EXPECT_LT((mesh.face_normal(t) - Vector3(1, 1, 1).normalized()).norm(), 1e-15);
  const Vector3 expected_edge = (Vector3(1, 1, 1).normalized() + Vector3(0, 0, -1)).normalized();
  EXPECT_LT((mesh.edge_pseudo_normal(t, 0) - expected_edge).norm(), 1e-15);
  // the origin's corner: three right angles, one per axis face
  EXPECT_LT((mesh.vertex_pseudo_normal(0) - Vector3(-1, -1, -1).normalized()).norm(), 1e-15);
}

TEST(TriangleMesh, OpenBoundaryEdgeTakesItsFaceNormal) {
  const TriangleMesh mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}});
  EXPECT_FALSE(mesh.is_closed());
  for (int e = 0; e < 3; ++e) EXPECT_EQ(mesh.edge_pseudo_normal(0, e), Vector3(0, 0, 1));
  for (int v = 0; v < 3; ++v) EXPECT_EQ(mesh.vertex_pseudo_normal(v), Vector3(0, 0, 1));
}

}  // namespace
}  // namespace hapticd::geometry
