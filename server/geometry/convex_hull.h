#pragma once

// The convex hull of a point set, built by Quickhull (Barber, Dobkin & Huhdanpaa 1996)
// with exact orientation tests, so a point is "outside" a face exactly when it is.
// The result is a closed, outward-oriented triangle surface with vertex adjacency
// (for hill-climbing support mappings) and an edge list with the faces beside each
// edge (for the Gauss-map tests of the penetration query).
//
// Degenerate input gives a lower-dimensional hull that the distance queries still
// accept: all points equal -> one vertex (dimension 0); collinear -> the segment
// between the two extreme points (dimension 1); coplanar -> the convex polygon
// (dimension 2), triangulated as a fan. Coplanar faces of a 3D hull stay triangulated;
// points exactly on a face or edge of the hull are dropped unless they were already
// vertices when that face appeared (they are then harmless, non-extreme vertices).

#include <array>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "server/geometry/types.h"

namespace hapticd::geometry {

struct ConvexHull {
  // -1: no (or non-finite) points; 0: one point; 1: a segment; 2: a convex polygon;
  // 3: a polyhedron.
  int dimension = -1;
  // Hull vertices, in the input frame; vertices[i] == points[input_index[i]].
  std::vector<Vector3> vertices;
  std::vector<int> input_index;
  // Dimension 3: outward triangles, counter-clockwise seen from outside (the exact
  // Orient3d of every other vertex against a face is <= 0). Dimension 2: a fan over
  // the polygon, counter-clockwise about plane_normal. Otherwise empty.
  std::vector<std::array<int, 3>> faces;
  // Unit normals of faces (rounded; the exact orientation is the winding of faces).
  std::vector<Vector3> face_normals;
  // Hull edges {i, j} with i < j: every triangle edge (dimension 3), the polygon's
  // boundary (2) or the segment (1).
  std::vector<std::array<int, 2>> edges;
  // Dimension 3 only: the two faces beside edges[e]; edge_faces[e][0] is the face in
  // which the edge runs i -> j.
  std::vector<std::array<int, 2>> edge_faces;
  // Vertex adjacency along hull edges, compressed: the neighbours of v are
  // adjacency[adjacency_start[v]] .. adjacency[adjacency_start[v + 1] - 1].
  std::vector<int> adjacency_start;
  std::vector<int> adjacency;
  // Dimension 2: unit normal of the polygon's plane. Dimension 1: unit direction of
  // the segment. Otherwise zero.
  Vector3 axis = Vector3::Zero();

  int num_vertices() const { return static_cast<int>(vertices.size()); }
  std::span<const int> neighbors(int v) const {
    return {adjacency.data() + adjacency_start[v],
            static_cast<size_t>(adjacency_start[v + 1] - adjacency_start[v])};
  }
};

// Builds the convex hull of points (any order, duplicates allowed). Preconditions:
// finite coordinates of magnitude below about 1e100 (ValidatePointSet). Empty or
// non-finite input gives dimension -1; never a crash or a hang. Allocates.
ConvexHull BuildConvexHull(std::span<const Vector3> points);

// Boundary check for a point set that will become a hull: returns an error message
// naming the first bad point's index and value (non-finite, or too large for the
// exact predicates), or that the set is empty; nullopt when the set is usable.
// name is how the message refers to the set, e.g. "a".
std::optional<std::string> ValidatePointSet(std::span<const Vector3> points,
                                            std::string_view name = "points");

// Largest coordinate magnitude ValidatePointSet accepts (exact predicates stay exact).
inline constexpr double kMaxHullCoordinate = 1e100;

}  // namespace hapticd::geometry
