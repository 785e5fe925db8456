#pragma once

// Random inputs shared by the geometry tests, drawn from the caller's generator so
// every test keeps its own fixed seed.

#include <cmath>
#include <random>
#include <vector>

#include "server/geometry/triangle_mesh.h"
#include "server/geometry/types.h"

namespace hapticd::geometry {

// A rotation uniformly distributed over SO(3) (a normalised Gaussian quaternion).
inline Matrix3 RandomRotation(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
  return q.normalized().toRotationMatrix();
}

// n points uniformly distributed in the ball of the given radius and centre.
inline std::vector<Vector3> RandomBall(std::mt19937_64& rng, int n, double radius,
                                       const Vector3& center = Vector3::Zero()) {
  std::normal_distribution<double> g(0, 1);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Vector3> points;
  for (int i = 0; i < n; ++i) {
    const Vector3 direction = Vector3(g(rng), g(rng), g(rng)).normalized();
    points.push_back(center + radius * std::cbrt(u(rng)) * direction);
  }
  return points;
}

// n random triangles in the unit cube (an open mesh), each with corners within `size`
// of a random point; triangle i has zero area (a repeated corner) when
// i % degenerate_every == degenerate_at, so meshes keep some degenerate triangles.
inline TriangleMesh MakeRandomSoup(std::mt19937_64& rng, int n, double size, int degenerate_every,
                                   int degenerate_at) {
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<Vector3> vertices;
  std::vector<TriangleMesh::TriangleIndices> triangles;
  for (int i = 0; i < n; ++i) {
    const Vector3 c(unit(rng), unit(rng), unit(rng));
    for (int k = 0; k < 3; ++k) {
      vertices.push_back(c + size * Vector3(unit(rng), unit(rng), unit(rng)));
    }
    const int b = 3 * i;
    triangles.push_back(i % degenerate_every == degenerate_at ? TriangleMesh::TriangleIndices{b, b + 1, b + 1}
                                                             : TriangleMesh::TriangleIndices{b, b + 1, b + 2});
  }
  return TriangleMesh(vertices, triangles);
}

}  // namespace hapticd::geometry
