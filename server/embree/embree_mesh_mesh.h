#pragma once

// Contacts between two EmbreeMeshes through rtcCollide: Embree walks both BVHs together
// and hands over every pair of primitives whose grown boxes overlap (a superset of the
// pairs that touch: the boxes contain their triangles exactly); each pair is then
// decided by the exact triangle-triangle test (server/geometry/triangle_triangle.h).
//
// rtcCollide takes no pose: both meshes must already be in one frame (build each
// EmbreeMesh from vertices placed in, say, the world frame). For meshes that move
// against each other every tick, use geometry::FindMeshMeshContacts with a pose.
//
// Setup-rate work, not for the real-time thread: Embree may spread the traversal over
// its worker threads and allocate while doing so. Results are then written through
// atomics, so they come in no particular order. Never throws.

#include <span>

#include "server/embree/embree_mesh.h"
#include "server/geometry/mesh_mesh_contacts.h"

namespace hapticd::embree {

// Every intersecting (triangle of a, triangle of b) pair, touching included, with the
// intersection segment, in the common frame. Equals, as a set,
// geometry::FindMeshMeshContacts(a.bvh(), b.bvh(), identity, out), which is exact under
// the identity. Pairs beyond out.size() are counted, not written (which ones are kept
// is unspecified). Meshes on different devices, or one mesh twice, are answered
// natively.
geometry::MeshMeshContacts FindMeshMeshContacts(const EmbreeMesh& a, const EmbreeMesh& b,
                                                std::span<geometry::MeshMeshContact> out);

// True when any triangle of a touches any triangle of b (both in one frame). Equals
// geometry::MeshesIntersect(a.bvh(), b.bvh(), identity).
bool MeshesIntersect(const EmbreeMesh& a, const EmbreeMesh& b);

}  // namespace hapticd::embree
