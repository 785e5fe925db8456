#pragma once

// Shared by the Embree backend's tests: test meshes, random segments, and the check
// that a backend answer equals the native exact one.

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "server/geometry/mesh_generators.h"
#include "server/geometry/mesh_queries.h"
#include "server/geometry/segment_triangle.h"
#include "server/geometry/test/random_geometry.h"
#include "server/geometry/triangle_mesh.h"

namespace hapticd::embree {

using geometry::SegmentMeshHit;
using geometry::TriangleMesh;
using geometry::Vector3;

inline std::shared_ptr<const TriangleMesh> Share(TriangleMesh mesh) {
  return std::make_shared<const TriangleMesh>(std::move(mesh));
}

// The mesh moved by the rigid motion x -> R x + t, in double (a new mesh in that frame).
inline TriangleMesh Moved(const TriangleMesh& mesh, const geometry::Matrix3& R, const Vector3& t) {
  std::vector<Vector3> vertices;
  for (const Vector3& v : mesh.vertices()) vertices.push_back(R * v + t);
  return TriangleMesh(vertices, mesh.triangles());
}

struct NamedMesh {
  std::string name;
  std::shared_ptr<const TriangleMesh> mesh;
};

// Closed meshes, one open soup with degenerate triangles, and a small mesh far from the
// origin (its guard is set by its distance, not its size).
inline std::vector<NamedMesh> TestMeshes() {
  std::mt19937_64 rng(7);
  return {{"icosphere", Share(geometry::MakeIcosphere(9, 1.0))},
          {"torus", Share(geometry::MakeTorus(1.0, 0.35, 36, 18))},
          {"box", Share(geometry::MakeBoxMesh({0.5, 1, 0.75}, 4))},
          {"soup", Share(geometry::MakeRandomSoup(rng, 400, 0.2, 9, 4))},
          {"far icosphere", Share(Moved(geometry::MakeIcosphere(6, 0.05),
                                        geometry::RandomRotation(rng), Vector3(10, -5, 3)))}};
}

// n segments with both ends uniform in the mesh's box grown by half its size on every
// side, and n short ones (a tenth of the size) centred near the surface.
inline std::vector<std::pair<Vector3, Vector3>> RandomSegments(const TriangleMesh& mesh, int n,
                                                               std::mt19937_64& rng) {
  const geometry::Aabb box = mesh.bounds().Inflated(0.5 * mesh.size());
  std::uniform_real_distribution<double> unit(0, 1);
  auto in_box = [&] {
    return Vector3(box.min + (box.max - box.min).cwiseProduct(Vector3(unit(rng), unit(rng), unit(rng))));
  };
  std::vector<std::pair<Vector3, Vector3>> segments;
  for (int i = 0; i < n; ++i) segments.push_back({in_box(), in_box()});
  std::uniform_int_distribution<int> pick(0, mesh.num_vertices() - 1);
  for (int i = 0; i < n; ++i) {
    const Vector3 center = mesh.vertices()[pick(rng)] + 0.02 * mesh.size() * geometry::RandomBall(rng, 1, 1.0)[0];
    const Vector3 half = 0.05 * mesh.size() * geometry::RandomBall(rng, 1, 1.0)[0];
    segments.push_back({center - half, center + half});
  }
  return segments;
}

// The backend answer equals the native exact one: same hit and t, and the same triangle
// (then the same u, v) or another one the watertight test hits at exactly that t.
inline ::testing::AssertionResult SameHit(const TriangleMesh& mesh, const Vector3& p, const Vector3& q,
                                          const SegmentMeshHit& native,
                                          const SegmentMeshHit& backend) {
  auto describe = [](const SegmentMeshHit& h) {
    return "{hit " + std::to_string(h.hit) + ", t " + std::to_string(h.t) + ", triangle " +
           std::to_string(h.triangle) + "}";
  };
  if (native.hit != backend.hit || native.t != backend.t) {
    return ::testing::AssertionFailure() << "native " << describe(native) << " backend "
                                         << describe(backend);
  }
  if (!native.hit) return ::testing::AssertionSuccess();
  if (native.triangle == backend.triangle) {
    if (native.u == backend.u && native.v == backend.v) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "same triangle, different u, v";
  }
  const geometry::TriangleHit tie =
      geometry::IntersectSegmentTriangleWatertight(p, q, mesh.triangle(backend.triangle));
  if (tie.hit && tie.t == native.t) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "native " << describe(native) << " backend "
                                       << describe(backend) << " is not a tie";
}

}  // namespace hapticd::embree
