#pragma once

// An immutable, validated triangle mesh: vertex positions, triangles as vertex index
// triples, and what the queries precompute from them (face normals and the
// angle-weighted pseudo-normals of Baerentzen & Aanaes 2005, "Signed distance
// computation using the angle weighted pseudonormal").
//
// Creation is the validation boundary: bad input throws std::invalid_argument with a
// message that names the bad value; nothing after creation throws. Triangles of
// exactly zero area (IsDegenerateTriangle), and exact repeats of an earlier triangle
// (the same three corner positions in any order or winding: a coincident copy adds
// nothing to hit but work), are kept in triangles() so indices stay the caller's, but
// they are marked degenerate and no query ever reports them.

#include <array>
#include <vector>

#include "server/geometry/aabb.h"
#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/types.h"

namespace hapticd::geometry {

class TriangleMesh {
 public:
  using TriangleIndices = std::array<int, 3>;

  // Validates and precomputes. Throws std::invalid_argument when there are no vertices
  // or no triangles (or more than 2^28), a vertex has a NaN or infinite coordinate, a
  // triangle refers to a vertex that does not exist (negative or >= vertices.size()), or
  // every triangle has zero area. Vertices that no triangle uses are allowed (and must
  // be finite too).
  TriangleMesh(std::vector<Vector3> vertices, std::vector<TriangleIndices> triangles);

  const std::vector<Vector3>& vertices() const { return vertices_; }
  // All triangles as given, degenerate ones included (original indices).
  const std::vector<TriangleIndices>& triangles() const { return triangles_; }
  int num_vertices() const { return static_cast<int>(vertices_.size()); }
  int num_triangles() const { return static_cast<int>(triangles_.size()); }

  // Original indices of the triangles with non-zero area that repeat no earlier one,
  // ascending: what the BVH and every query work on.
  const std::vector<int>& nondegenerate_triangles() const { return nondegenerate_; }
  // Triangles dropped: zero-area ones and repeats together, and the repeats alone.
  int num_degenerate_triangles() const {
    return num_triangles() - static_cast<int>(nondegenerate_.size());
  }
  int num_repeated_triangles() const { return num_repeated_; }
  bool is_degenerate(int t) const { return degenerate_[t] != 0; }

  // Corners of original triangle t, in the order that defines its normal.
  Triangle triangle(int t) const {
    const TriangleIndices& f = triangles_[t];
    return {vertices_[f[0]], vertices_[f[1]], vertices_[f[2]]};
  }

  // Box around the vertices of the non-degenerate triangles.
  const Aabb& bounds() const { return bounds_; }
  // Longest side of bounds(): the length scale of tolerances.
  double size() const { return bounds_.size().maxCoeff(); }

  // Closed: over the non-degenerate triangles, every undirected edge (by vertex index,
  // not position) is shared by exactly two triangles that traverse it in opposite
  // directions. Only then do inside and outside mean something.
  bool is_closed() const { return closed_; }
  // Signed volume enclosed, (1/6) sum v0 . (v1 x v2) over the non-degenerate
  // triangles: positive when a closed mesh's normals point outwards.
  double signed_volume() const { return signed_volume_; }

  // Unit normal of triangle t (the right-handed normal of v0, v1, v2); zero for a
  // degenerate triangle, or where the cross product underflows.
  const Vector3& face_normal(int t) const { return face_normals_[t]; }
  // Pseudo-normal of edge e of triangle t (e = 0: v0-v1, 1: v1-v2, 2: v2-v0): the
  // normalised sum of the normals of the triangles sharing that undirected edge (just
  // t's normal on an open boundary).
  const Vector3& edge_pseudo_normal(int t, int e) const { return edge_normals_[3 * t + e]; }
  // Angle-weighted pseudo-normal of vertex v: the normalised sum over the
  // non-degenerate triangles at v of (corner angle) x (face normal); zero when unused.
  const Vector3& vertex_pseudo_normal(int v) const { return vertex_normals_[v]; }
  // The pseudo-normal of the given feature of triangle t (a vertex, edge or the face).
  const Vector3& FeatureNormal(int t, TriangleFeature feature) const;

 private:
  void Validate() const;
  void ComputeFaceData();
  void DropRepeatedTriangles();
  void ComputeEdgeData();
  void ComputeVertexNormals();

  std::vector<Vector3> vertices_;
  std::vector<TriangleIndices> triangles_;
  std::vector<char> degenerate_;
  std::vector<int> nondegenerate_;
  int num_repeated_ = 0;
  Aabb bounds_;
  bool closed_ = false;
  double signed_volume_ = 0;
  std::vector<Vector3> face_normals_;
  std::vector<Vector3> edge_normals_;
  std::vector<Vector3> vertex_normals_;
};

}  // namespace hapticd::geometry
