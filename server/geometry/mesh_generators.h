#pragma once

// Closed, outward-oriented test meshes for tests and benchmarks. Each is centred at
// the origin. Vertices shared by neighbouring triangles are shared by index, and are
// computed once, so the meshes are closed (TriangleMesh::is_closed()) exactly.
// Invalid parameters throw std::invalid_argument naming the value.

#include "server/geometry/triangle_mesh.h"

namespace hapticd::geometry {

// Geodesic sphere: each edge of an icosahedron is split into `frequency` >= 1 parts
// and the grid points are pushed onto the sphere of `radius` > 0. 20 frequency^2
// triangles, 10 frequency^2 + 2 vertices (frequency 22: 9,680; 71: 100,820; 224:
// 1,003,520 triangles).
TriangleMesh MakeIcosphere(int frequency, double radius);

// Torus around the z axis: tube centre circle of `major_radius`, tube of
// `minor_radius` (0 < minor_radius < major_radius), with major_segments x
// minor_segments (each >= 3) quads split into 2 triangles each.
TriangleMesh MakeTorus(double major_radius, double minor_radius, int major_segments,
                       int minor_segments);

// Axis-aligned box with the given half extents (each > 0); each face is a
// divisions x divisions grid (divisions >= 1) of squares split into 2 triangles:
// 12 divisions^2 triangles. Grid coordinates are h (2 i - divisions) / divisions, so
// dyadic half extents and a power-of-two divisions give exactly representable vertices.
TriangleMesh MakeBoxMesh(const Vector3& half_extents, int divisions = 1);

}  // namespace hapticd::geometry
