#pragma once

// An immutable, validated triangle mesh: vertex positions, triangles as vertex index
// triples, and what the queries precompute from them (face normals and the
// angle-weighted pseudo-normals of Baerentzen & Aanaes 2005, "Signed distance
// computation using the angle weighted pseudonormal").
//
// Creation is the validation boundary: bad input throws std::invalid_argument with a
// message that names the bad value; nothing after creation throws. Triangles of
// exactly zero area (IsDegenerateTriangle), triangles too small for their normal to be
// computed in double precision (the squared length of the edges' cross product below
// the smallest normal double: edges shorter than about 1e-77 m), and exact repeats of an earlier triangle
// (the same three corner positions in any order or winding: a coincident copy adds
// nothing to hit but work), are kept in triangles() so indices stay the caller's, but
// they are marked degenerate and no query ever reports them.
//
// Orientation is fixed at creation too: where the triangles close up into shells (every
// edge, by vertex index, shared by exactly two of them), each shell's winding is made
// consistent and turned so that its normals point away from the solid (out of a body,
// into a cavity nested inside one); the triangles so rewound keep their index and have
// their corners 1 and 2 swapped in triangles(). A mesh with a boundary or a
// non-manifold edge, or whose shells admit no consistent winding, is open: a surface
// with no inside, kept as given.

#include <array>
#include <string_view>
#include <vector>

#include "server/geometry/aabb.h"
#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/types.h"

namespace hapticd::geometry {

// How the non-degenerate triangles bound a solid.
enum class MeshClosure {
  kClosed,         // every edge shared by exactly two triangles, wound consistently: a solid
  kOpen,           // some edge has one triangle, or more than two: a surface
  kNonOrientable,  // every edge has two triangles, but no winding makes them agree
                   // (a Moebius-like shell): a surface like kOpen
  kCount,
};
// "closed", "open", "non-orientable".
std::string_view MeshClosureName(MeshClosure closure);

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
  // All triangles as given, degenerate ones included (original indices), the rewound
  // ones with corners 1 and 2 swapped.
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
  // directions (after rewinding). Only then do inside and outside mean something.
  bool is_closed() const { return closure_ == MeshClosure::kClosed; }
  MeshClosure closure() const { return closure_; }
  // Triangles whose winding creation reversed (0 unless closed): a shell given inside
  // out, or triangles wound against their neighbours.
  int num_rewound_triangles() const { return num_rewound_; }
  // Closed shells (connected components), and whether each one's nesting among the
  // others was decided: false when there were so many shells inside each other's boxes
  // that the check would have cost more than about 3e7 triangle visits; the shells not
  // checked were each turned outwards, as if none were a cavity.
  int num_shells() const { return num_shells_; }
  bool nesting_checked() const { return nesting_checked_; }
  // Signed volume enclosed, (1/6) sum v0 . (v1 x v2) over the non-degenerate
  // triangles: positive for a closed mesh (its normals point outwards), unless its
  // shells enclose no volume at all.
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
  void FindDegenerateTriangles();
  void DropRepeatedTriangles();
  void OrientShells();
  void ComputeFaceData();
  void ComputeEdgeData();
  void ComputeVertexNormals();

  std::vector<Vector3> vertices_;
  std::vector<TriangleIndices> triangles_;
  std::vector<char> degenerate_;
  std::vector<int> nondegenerate_;
  int num_repeated_ = 0;
  MeshClosure closure_ = MeshClosure::kOpen;
  int num_rewound_ = 0;
  int num_shells_ = 0;
  bool nesting_checked_ = true;
  Aabb bounds_;
  double signed_volume_ = 0;
  std::vector<Vector3> face_normals_;
  std::vector<Vector3> edge_normals_;
  std::vector<Vector3> vertex_normals_;
};

}  // namespace hapticd::geometry
