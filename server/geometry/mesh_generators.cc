#include "server/geometry/mesh_generators.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace hapticd::geometry {
namespace {

using Indices = TriangleMesh::TriangleIndices;

// The 12 vertices and 20 outward (counter-clockwise) faces of an icosahedron.
constexpr double kPhi = std::numbers::phi;
const std::array<Vector3, 12> kIcosahedronVertices = {
    Vector3(-1, kPhi, 0), Vector3(1, kPhi, 0), Vector3(-1, -kPhi, 0), Vector3(1, -kPhi, 0),
    Vector3(0, -1, kPhi), Vector3(0, 1, kPhi), Vector3(0, -1, -kPhi), Vector3(0, 1, -kPhi),
    Vector3(kPhi, 0, -1), Vector3(kPhi, 0, 1), Vector3(-kPhi, 0, -1), Vector3(-kPhi, 0, 1)};
constexpr std::array<std::array<int, 3>, 20> kIcosahedronFaces = {{
    {0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11},
    {1, 5, 9}, {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
    {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8}, {3, 8, 9},
    {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}}};

// Adds the two triangles of quad a-b-c-d (counter-clockwise seen from outside).
void AddQuad(std::vector<Indices>& triangles, int a, int b, int c, int d) {
  triangles.push_back({a, b, c});
  triangles.push_back({a, c, d});
}

}  // namespace

// A grid point of a face with corners A, B, C is (wa A + wb B + wc C) / frequency with
// wa + wb + wc = frequency. Points on a shared edge or corner are keyed by their
// non-zero (corner index, weight) pairs sorted by corner index, and their position is
// computed from that key alone, so both faces get the same vertex, bit for bit.
TriangleMesh MakeIcosphere(int frequency, double radius) {
  if (frequency < 1 || frequency > 4096) {
    throw std::invalid_argument("icosphere frequency must be in 1..4096, got " +
                                std::to_string(frequency));
  }
  if (!(radius > 0) || !std::isfinite(radius)) {
    throw std::invalid_argument("icosphere radius must be positive and finite, got " +
                                std::to_string(radius));
  }
  std::vector<Vector3> vertices;
  std::vector<Indices> triangles;
  vertices.reserve(10 * static_cast<size_t>(frequency) * frequency + 2);
  triangles.reserve(20 * static_cast<size_t>(frequency) * frequency);
  std::unordered_map<uint64_t, int> index_of_key;

  // vertex index of the grid point with the given corner weights
  auto vertex = [&](const std::array<int, 3>& corners, const std::array<int, 3>& weights) {
    std::array<std::pair<int, int>, 3> terms = {std::pair{corners[0], weights[0]},
                                                std::pair{corners[1], weights[1]},
                                                std::pair{corners[2], weights[2]}};
    std::sort(terms.begin(), terms.end());
    uint64_t key = 0;
    Vector3 sum = Vector3::Zero();
    for (const auto& [corner, weight] : terms) {
      if (weight == 0) continue;
      key = (key << 20) | (static_cast<uint64_t>(corner) << 16) | static_cast<uint64_t>(weight);
      sum += weight * kIcosahedronVertices[corner];
    }
    const auto [it, inserted] = index_of_key.try_emplace(key, static_cast<int>(vertices.size()));
    if (inserted) vertices.push_back(radius * sum.normalized());
    return it->second;
  };

  const int f = frequency;
  std::vector<int> grid((f + 1) * (f + 1));
  for (const auto& face : kIcosahedronFaces) {
    // grid point (i, j) = A + i/f (B - A) + j/f (C - A)
    for (int i = 0; i <= f; ++i) {
      for (int j = 0; i + j <= f; ++j) grid[i * (f + 1) + j] = vertex(face, {f - i - j, i, j});
    }
    auto at = [&](int i, int j) { return grid[i * (f + 1) + j]; };
    // an upward triangle at each grid point, a downward one where it fits
    for (int i = 0; i < f; ++i) {
      for (int j = 0; i + j < f; ++j) {
        triangles.push_back({at(i, j), at(i + 1, j), at(i, j + 1)});
        if (i + j + 1 < f) triangles.push_back({at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)});
      }
    }
  }
  return TriangleMesh(std::move(vertices), std::move(triangles));
}

TriangleMesh MakeTorus(double major_radius, double minor_radius, int major_segments,
                       int minor_segments) {
  if (!(minor_radius > 0) || !(major_radius > minor_radius) || !std::isfinite(major_radius)) {
    throw std::invalid_argument("torus radii must satisfy 0 < minor < major < inf, got major " +
                                std::to_string(major_radius) + ", minor " +
                                std::to_string(minor_radius));
  }
  if (major_segments < 3 || minor_segments < 3 ||
      static_cast<long long>(major_segments) * minor_segments > (1 << 26)) {
    throw std::invalid_argument("torus needs 3 or more segments each way (and at most 2^26 "
                                "quads), got " + std::to_string(major_segments) + " x " +
                                std::to_string(minor_segments));
  }
  // vertex (i, j): angle u = 2 pi i / major_segments around z, v = 2 pi j /
  // minor_segments around the tube; d/du x d/dv points out of the tube
  std::vector<Vector3> vertices;
  vertices.reserve(static_cast<size_t>(major_segments) * minor_segments);
  for (int i = 0; i < major_segments; ++i) {
    const double u = 2 * std::numbers::pi * i / major_segments;
    for (int j = 0; j < minor_segments; ++j) {
      const double v = 2 * std::numbers::pi * j / minor_segments;
      const double ring = major_radius + minor_radius * std::cos(v);
      vertices.emplace_back(ring * std::cos(u), ring * std::sin(u), minor_radius * std::sin(v));
    }
  }
  std::vector<Indices> triangles;
  triangles.reserve(2 * vertices.size());
  auto at = [&](int i, int j) {
    return (i % major_segments) * minor_segments + j % minor_segments;
  };
  for (int i = 0; i < major_segments; ++i) {
    for (int j = 0; j < minor_segments; ++j) {
      AddQuad(triangles, at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
    }
  }
  return TriangleMesh(std::move(vertices), std::move(triangles));
}

TriangleMesh MakeBoxMesh(const Vector3& half_extents, int divisions) {
  if (!(half_extents.array() > 0).all() || !half_extents.allFinite()) {
    throw std::invalid_argument("box half extents must be positive and finite, got [" +
                                std::to_string(half_extents.x()) + ", " +
                                std::to_string(half_extents.y()) + ", " +
                                std::to_string(half_extents.z()) + "]");
  }
  if (divisions < 1 || divisions > 4096) {
    throw std::invalid_argument("box divisions must be in 1..4096, got " +
                                std::to_string(divisions));
  }
  const int n = divisions;
  std::vector<Vector3> vertices;
  std::vector<Indices> triangles;
  std::unordered_map<int64_t, int> index_of_grid_point;
  // vertex index of surface grid point (i, j, k), each in 0..n
  auto vertex = [&](const std::array<int, 3>& g) {
    const int64_t key = (static_cast<int64_t>(g[0]) * (n + 1) + g[1]) * (n + 1) + g[2];
    const auto [it, inserted] =
        index_of_grid_point.try_emplace(key, static_cast<int>(vertices.size()));
    if (inserted) {
      Vector3 p;
      for (int axis = 0; axis < 3; ++axis) p[axis] = half_extents[axis] * (2 * g[axis] - n) / n;
      vertices.push_back(p);
    }
    return it->second;
  };
  // each face: the fixed axis and its side, and in-face axes a, b with a x b outward
  struct Face {
    int fixed, side, a, b;
  };
  constexpr std::array<Face, 6> kFaces = {{
      {0, 1, 1, 2}, {0, 0, 2, 1}, {1, 1, 2, 0}, {1, 0, 0, 2}, {2, 1, 0, 1}, {2, 0, 1, 0}}};
  for (const Face& face : kFaces) {
    auto at = [&](int s, int t) {
      std::array<int, 3> g;
      g[face.fixed] = face.side * n;
      g[face.a] = s;
      g[face.b] = t;
      return vertex(g);
    };
    for (int s = 0; s < n; ++s) {
      for (int t = 0; t < n; ++t) {
        AddQuad(triangles, at(s, t), at(s + 1, t), at(s + 1, t + 1), at(s, t + 1));
      }
    }
  }
  return TriangleMesh(std::move(vertices), std::move(triangles));
}

}  // namespace hapticd::geometry
