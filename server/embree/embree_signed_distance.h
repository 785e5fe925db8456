#pragma once

// Inside/outside and signed distance of a point for an EmbreeMesh, decided as
// geometry::CalcSignedDistanceToMesh decides them: the closest point (through Embree,
// embree_closest_point.h), a point exactly on a triangle found by exact predicates
// (candidates through an Embree point query of radius guard()), then the side of the
// closest feature's angle-weighted pseudo-normal.
//
// Where several triangles are exactly as close, the native query reports whichever its
// traversal meets first, and Embree's traversal may meet another. Both give the same
// distance, and nearly always the same side; where exact ties disagree on the side (p
// within rounding of the surface near an edge, or on a medial axis), the side is the
// native query's own pick, so the native query answers that point.
//
// The point is in the mesh's frame, distances in its units. Thread-safe,
// allocation-free, never throws.

#include "server/embree/embree_mesh.h"
#include "server/geometry/mesh_queries.h"
#include "server/geometry/types.h"

namespace hapticd::embree {

// Signed distance (-inside, +outside, 0 on the surface) and side of p for a closed mesh;
// on the surface counts as inside; a mesh wound inwards is treated as its outward twin;
// on an open mesh the sign is that of the nearest surface's pseudo-normal. Equals
// geometry::CalcSignedDistanceToMesh(mesh.bvh(), p): the same inside and signed
// distance; where several triangles are exactly as close, closest may name another of
// them. NaN or infinite p gives an empty answer (not found, outside); a point beyond the
// mesh's trust bound is answered by the native BVH.
geometry::MeshSignedDistance CalcSignedDistanceToMesh(const EmbreeMesh& mesh,
                                                      const geometry::Vector3& p);

// CalcSignedDistanceToMesh(mesh, p).inside: false for NaN or infinite p.
bool IsPointInsideMesh(const EmbreeMesh& mesh, const geometry::Vector3& p);

}  // namespace hapticd::embree
