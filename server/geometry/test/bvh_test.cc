#include "server/geometry/bvh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "server/geometry/bvh_simd.h"
#include "server/geometry/capsule_triangle.h"
#include "server/geometry/mesh_generators.h"
#include "server/geometry/test/random_geometry.h"

namespace hapticd::geometry {
namespace {

using Indices = TriangleMesh::TriangleIndices;

// The primitives under child c of a node, found by walking down.
std::vector<int> PrimitivesUnder(const MeshBvh& bvh, int node, int c) {
  const BvhNode& n = bvh.nodes()[node];
  if (n.is_leaf(c)) {
    std::vector<int> all(n.count[c]);
    for (int i = 0; i < n.count[c]; ++i) all[i] = n.first_primitive(c) + i;
    return all;
  }
  std::vector<int> all;
  for (int k = 0; k < kBvhWidth; ++k) {
    const std::vector<int> below = PrimitivesUnder(bvh, n.child[c], k);
    all.insert(all.end(), below.begin(), below.end());
  }
  return all;
}

// Each child of at most kMaxDiscTriangles triangles has a finite disc that holds every
// corner under it (to the float normal's rounding); the others have an infinite one.
void ExpectDiscsHoldTheirChildren(const MeshBvh& bvh, const std::string& what) {
  ASSERT_EQ(bvh.discs().size(), bvh.nodes().size()) << what;
  int finite = 0;
  for (int node = 0; node < static_cast<int>(bvh.nodes().size()); ++node) {
    const BvhDiscs& discs = bvh.discs()[node];
    for (int c = 0; c < kBvhWidth; ++c) {
      const std::vector<int> under = PrimitivesUnder(bvh, node, c);
      if (!std::isfinite(discs.radius[c])) {
        EXPECT_EQ(discs.thickness[c], std::numeric_limits<float>::infinity()) << what;
        const bool small = !under.empty() && under.size() <= kMaxDiscTriangles;
        // (a small child is left infinite only where float cannot hold its disc)
        if (small) {
          EXPECT_GT(bvh.bounds().size().norm(), 1e30) << what << ": node " << node << " child " << c;
        }
        continue;
      }
      ++finite;
      EXPECT_LE(under.size(), kMaxDiscTriangles) << what;
      const Vector3 centre(discs.centre[0][c], discs.centre[1][c], discs.centre[2][c]);
      const Vector3 normal(discs.normal[0][c], discs.normal[1][c], discs.normal[2][c]);
      EXPECT_NEAR(normal.norm(), 1, 1e-6) << what;
      for (const int i : under) {
        const Triangle& t = bvh.primitive(i);
        for (const Vector3& corner : {t.v0, t.v1, t.v2}) {
          const Vector3 offset = corner - centre;
          const double height = offset.dot(normal.normalized());
          const double slack = 1e-6 * offset.norm();
          EXPECT_LE(std::abs(height), discs.thickness[c] + slack) << what << ": node " << node << " child " << c;
          EXPECT_LE((offset - height * normal.normalized()).norm(), discs.radius[c] + slack)
              << what << ": node " << node << " child " << c;
        }
      }
    }
  }
  // (a mesh beyond float's range has none)
  if (bvh.bounds().size().norm() < 1e30) {
    EXPECT_GT(finite, 0) << what;
  }
}

// Checks the structure of a BVH against its mesh:
//  - every node is reached exactly once from the root, and no slot is left unused;
//  - every non-degenerate triangle sits in exactly one leaf, degenerate ones in none;
//  - each child box contains both boxes of the child node below it, and each leaf box
//    contains its triangles' double-precision boxes;
//  - the leaf-order copy matches the mesh, depth() is the real depth and within bounds.
void ExpectValidBvh(const MeshBvh& bvh, const BvhBuildOptions& options, const std::string& what) {
  const TriangleMesh& mesh = bvh.mesh();
  const std::vector<BvhNode>& nodes = bvh.nodes();
  ASSERT_FALSE(nodes.empty()) << what;
  ASSERT_EQ(bvh.num_primitives(), static_cast<int>(mesh.nondegenerate_triangles().size())) << what;
  std::vector<int> node_visits(nodes.size(), 0);
  std::vector<int> primitive_visits(bvh.num_primitives(), 0);
  std::vector<int> triangle_visits(mesh.num_triangles(), 0);
  int max_depth = 0;
  // (node, depth) pairs still to check
  std::vector<std::pair<int, int>> todo = {{0, 1}};
  while (!todo.empty()) {
    const auto [index, depth] = todo.back();
    todo.pop_back();
    ASSERT_GE(index, 0) << what;
    ASSERT_LT(index, static_cast<int>(nodes.size())) << what;
    ++node_visits[index];
    max_depth = std::max(max_depth, depth);
    const BvhNode& node = nodes[index];
    int used = 0;
    for (int c = 0; c < kBvhWidth; ++c) {
      const Aabb box = node.child_bounds(c);
      if (!node.is_leaf(c)) {
        ++used;
        const BvhNode& below = nodes[node.child[c]];
        for (int k = 0; k < kBvhWidth; ++k) {
          if (below.is_empty(k)) continue;
          EXPECT_TRUE(box.Contains(below.child_bounds(k))) << what << ": node " << index;
        }
        todo.push_back({node.child[c], depth + 1});
        continue;
      }
      const int first = node.first_primitive(c), count = node.count[c];
      // an unused slot has an empty box, which nothing can touch
      if (count == 0) {
        EXPECT_TRUE(box.empty()) << what;
        EXPECT_TRUE((box.min.array() == std::numeric_limits<double>::infinity()).all()) << what;
        continue;
      }
      ++used;
      EXPECT_LE(count, options.max_leaf_size) << what;
      for (int i = first; i < first + count; ++i) {
        ASSERT_LT(i, bvh.num_primitives()) << what;
        ++primitive_visits[i];
        const int t = bvh.primitive_triangle(i);
        ++triangle_visits[t];
        const Triangle expected = mesh.triangle(t);
        EXPECT_EQ(bvh.primitive(i).v0, expected.v0);
        EXPECT_EQ(bvh.primitive(i).v1, expected.v1);
        EXPECT_EQ(bvh.primitive(i).v2, expected.v2);
        EXPECT_TRUE(box.Contains(Aabb::OfTriangle(expected)))
            << what << ": leaf box misses triangle " << t;
      }
    }
    // every node but a lone-leaf root splits its triangles at least in two
    EXPECT_GE(used, index == 0 && nodes.size() == 1 ? 1 : 2) << what << ": node " << index;
  }
  for (size_t i = 0; i < nodes.size(); ++i) EXPECT_EQ(node_visits[i], 1) << what << ": node " << i;
  for (int i = 0; i < bvh.num_primitives(); ++i) EXPECT_EQ(primitive_visits[i], 1) << what;
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    EXPECT_EQ(triangle_visits[t], mesh.is_degenerate(t) ? 0 : 1) << what << ": triangle " << t;
  }
  EXPECT_EQ(bvh.depth(), max_depth) << what;
  EXPECT_LE(bvh.depth(), kMaxBvhDepth) << what;
  // the root box holds the whole mesh
  EXPECT_TRUE(bvh.bounds().Contains(mesh.bounds())) << what;
}

std::vector<std::pair<std::string, std::shared_ptr<const TriangleMesh>>> TestMeshes() {
  std::mt19937_64 rng(7);
  std::vector<std::pair<std::string, std::shared_ptr<const TriangleMesh>>> meshes;
  auto add = [&](std::string name, TriangleMesh mesh) {
    meshes.emplace_back(std::move(name), std::make_shared<const TriangleMesh>(std::move(mesh)));
  };
  add("icosphere", MakeIcosphere(12, 1.5));
  add("torus", MakeTorus(2, 0.5, 40, 20));
  add("box", MakeBoxMesh({1, 2, 3}, 6));
  add("soup", MakeRandomSoup(rng, 3000, 0.05, 17, 5));
  add("one triangle", TriangleMesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}}));
  // many triangles with one centroid (a fan of rotated copies): no SAH split exists
  {
    std::vector<Vector3> v;
    std::vector<Indices> t;
    for (int i = 0; i < 100; ++i) {
      const double a = 0.031 * i;
      const Vector3 d(std::cos(a), std::sin(a), 0), e(-std::sin(a), std::cos(a), 0.5);
      v.push_back(d);
      v.push_back(-d + e);
      v.push_back(-e);
      t.push_back({3 * i, 3 * i + 1, 3 * i + 2});
    }
    add("same centroids", TriangleMesh(v, t));
  }
  // exponentially spread triangles: the SAH peels off one at a time, so the build
  // must fall back to median splits to stay within the depth bound
  {
    std::vector<Vector3> v;
    std::vector<Indices> t;
    for (int i = 0; i < 4000; ++i) {
      const double x = std::pow(1.02, i);
      v.push_back({x, 0, 0});
      v.push_back({x, 1, 0});
      v.push_back({x, 0, 1});
      t.push_back({3 * i, 3 * i + 1, 3 * i + 2});
    }
    add("exponential", TriangleMesh(v, t));
  }
  // coordinates beyond the float range: boxes must become infinite, not wrong
  add("huge", TriangleMesh({{-1e40, 0, 0}, {1e40, 1, 0}, {0, 1e39, 1}, {5, 5, 5}},
                           {{0, 1, 2}, {1, 3, 2}}));
  return meshes;
}

TEST(MeshBvh, StructureInvariantsHold) {
  for (const auto& [name, mesh] : TestMeshes()) {
    for (int leaf : {1, 4, 16}) {
      for (int threads : {1, 2, 3}) {
        BvhBuildOptions options;
        options.max_leaf_size = leaf;
        options.num_threads = threads;
        const MeshBvh bvh(mesh, options);
        const std::string what = name + " leaf " + std::to_string(leaf) + " threads " + std::to_string(threads);
        ExpectValidBvh(bvh, options, what);
        ExpectDiscsHoldTheirChildren(bvh, what);
      }
    }
  }
}

TEST(MeshBvh, ThreadCountDoesNotChangeTheTree) {
  const auto mesh = std::make_shared<const TriangleMesh>(MakeIcosphere(40, 1.0));  // 32k
  BvhBuildOptions one;
  one.num_threads = 1;
  const MeshBvh serial(mesh, one);
  for (int threads : {2, 4}) {
    BvhBuildOptions options;
    options.num_threads = threads;
    const MeshBvh parallel(mesh, options);
    ASSERT_EQ(parallel.nodes().size(), serial.nodes().size());
    EXPECT_EQ(std::memcmp(parallel.nodes().data(), serial.nodes().data(),
                          serial.nodes().size() * sizeof(BvhNode)),
              0);
    for (int i = 0; i < serial.num_primitives(); ++i) {
      ASSERT_EQ(parallel.primitive_triangle(i), serial.primitive_triangle(i));
    }
  }
}

TEST(MeshBvh, ExponentialSpreadStaysWithinDepthBound) {
  const auto meshes = TestMeshes();
  for (const auto& [name, mesh] : meshes) {
    if (name != "exponential") continue;
    // the SAH alone would peel off a few triangles per level, 1000 levels deep
    const MeshBvh bvh(mesh);
    EXPECT_LE(bvh.depth(), kMaxBvhDepth);
    EXPECT_GT(bvh.depth(), 12);
  }
}

TEST(MeshBvh, BoxesBeyondFloatRangeAreInfinite) {
  const auto mesh = std::make_shared<const TriangleMesh>(
      TriangleMesh({{-1e40, 0, 0}, {1e40, 1, 0}, {0, 1e39, 1}}, {{0, 1, 2}}));
  const MeshBvh bvh(mesh);
  const Aabb box = bvh.bounds();
  EXPECT_EQ(box.min.x(), -std::numeric_limits<double>::infinity());
  EXPECT_EQ(box.max.x(), std::numeric_limits<double>::infinity());
  EXPECT_EQ(box.max.y(), std::numeric_limits<double>::infinity());
  EXPECT_EQ(box.min.y(), 0);
  EXPECT_EQ(box.max.z(), 1);
}

TEST(MeshBvh, FloatBoxesAreRoundedOutwards) {
  // 0.1 and 0.7 are not floats: the box must still contain them
  const auto mesh = std::make_shared<const TriangleMesh>(
      TriangleMesh({{0.1, -0.1, 0.7}, {0.3, -0.7, 0.1}, {-0.3, 0.3, 0.3}}, {{0, 1, 2}}));
  const MeshBvh bvh(mesh);
  const Aabb box = bvh.nodes()[0].child_bounds(0);
  EXPECT_TRUE(box.Contains(mesh->bounds()));
  EXPECT_LT(box.min.x(), -0.3);
  EXPECT_GT(box.max.z(), 0.7);
  // and by no more than a float's rounding
  EXPECT_LT((box.size() - mesh->bounds().size()).norm(), 1e-6);
}

// The gather's disc test (bvh_simd::FloatDiscsWithin) passes over a child only when no
// triangle under it lies within the distance of the segment (brute force): on segments
// from near random corners of four meshes, and on a sphere avatar resting on the
// icosphere and on the torus's outer equator (radius 1 to 6 mm, the distance 40 um more,
// moving up to 0.5 mm along the surface), where the boxes keep a ring of leaves beyond
// the distance. There it passes over most of that ring: what it is for.
TEST(BvhDiscs, PassOverOnlyWhatLiesBeyondTheDistance) {
  std::mt19937_64 rng(1204);
  std::uniform_real_distribution<double> unit(0, 1);
  const auto direction = [&] {
    const Vector3 v(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5);
    return Vector3(v.normalized());
  };
  struct Surface {
    std::string name;
    TriangleMesh mesh;
    // where a sphere of radius r rests on it (none: only random segments)
    std::function<Vector3(double r)> resting;
  };
  const Surface surfaces[] = {
      {"icosphere", MakeIcosphere(40, 0.05), [&](double r) { return Vector3((0.05 + r) * direction()); }},
      {"torus", MakeTorus(0.05, 0.02, 400, 160),
       [&](double r) {
         const double angle = 2 * M_PI * unit(rng);
         return Vector3((0.07 + r) * Vector3(std::cos(angle), std::sin(angle), 0));
       }},
      {"box", MakeBoxMesh({0.1, 0.06, 0.04}, 30), nullptr},
      {"soup", MakeRandomSoup(rng, 4000, 0.02, 17, 5), nullptr},
  };
  for (const Surface& surface : surfaces) {
    const MeshBvh bvh(std::make_shared<const TriangleMesh>(surface.mesh));
    int ring = 0;  // leaves the boxes keep beyond the distance of a resting sphere
    int ring_passed_over = 0;
    for (int trial = 0; trial < 120; ++trial) {
      const bool rests = surface.resting && trial % 2 == 0;
      Vector3 a, b;
      double keep;
      if (rests) {
        const double r = 0.001 + 0.005 * unit(rng);
        a = surface.resting(r);
        const Vector3 along = direction();
        b = a + 0.0005 * unit(rng) * (along - along.dot(a.normalized()) * a.normalized());
        keep = r + 4e-5;
      } else {
        // from near a corner of the mesh, up to 6 mm away, moving up to 2 mm
        const Vector3 corner = surface.mesh.vertices()[rng() % surface.mesh.vertices().size()];
        a = corner + 0.006 * unit(rng) * direction();
        b = trial % 3 == 0 ? a : Vector3(a + 0.002 * unit(rng) * direction());
        keep = 0.006 * unit(rng);
      }
      const bvh_simd::FloatBoxWithin boxes(Aabb{a.cwiseMin(b), a.cwiseMax(b)}, keep);
      const bvh_simd::FloatDiscsWithin discs(a, b - a, keep);
      std::vector<int> todo = {0};
      while (!todo.empty()) {
        const int node = todo.back();
        todo.pop_back();
        const int by_box = boxes.ChildrenWithin(bvh.nodes()[node]);
        const int by_disc = discs.ChildrenWithin(bvh.discs()[node]);
        for (int c = 0; c < kBvhWidth; ++c) {
          if (!(by_box >> c & 1)) continue;
          if (!bvh.nodes()[node].is_leaf(c)) todo.push_back(bvh.nodes()[node].child[c]);
          const std::vector<int> under = PrimitivesUnder(bvh, node, c);
          if (under.size() > kMaxDiscTriangles) {
            EXPECT_TRUE(by_disc >> c & 1) << surface.name << ": an infinite disc keeps everything";
            continue;
          }
          double nearest = std::numeric_limits<double>::infinity();
          for (const int i : under) {
            nearest = std::min(nearest, CalcCapsuleTriangleContact({a, b, 0}, bvh.primitive(i)).distance);
          }
          const bool passed_over = !(by_disc >> c & 1);
          if (passed_over) {
            EXPECT_GT(nearest, keep) << surface.name << " trial " << trial << ": node " << node << " child " << c;
          }
          if (rests && bvh.nodes()[node].is_leaf(c) && nearest > keep) {
            ++ring;
            ring_passed_over += passed_over;
          }
        }
      }
    }
    if (surface.resting) {
      EXPECT_GT(ring, 300) << surface.name;
      EXPECT_GT(ring_passed_over, ring / 2) << surface.name;
    }
  }
}

TEST(MeshBvh, RejectsNullMeshAndBadOptions) {
  EXPECT_THROW(MeshBvh(nullptr), std::invalid_argument);
  const auto mesh = std::make_shared<const TriangleMesh>(MakeBoxMesh({1, 1, 1}));
  BvhBuildOptions options;
  options.max_leaf_size = 0;
  EXPECT_THROW(MeshBvh(mesh, options), std::invalid_argument);
  options.max_leaf_size = 4;
  options.num_threads = 0;
  EXPECT_THROW(MeshBvh(mesh, options), std::invalid_argument);
}

}  // namespace
}  // namespace hapticd::geometry
