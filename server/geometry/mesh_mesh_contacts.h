#pragma once

// Contacts between two triangle meshes under a relative pose: every pair of triangles
// that intersect, with their intersection segment. Both BVHs are walked together
// (each box of B, moved into A's frame, is bounded by an axis-aligned box there), and
// every candidate pair is decided exactly by the triangle-triangle test on B's
// triangle moved into A's frame (touching counts).
//
// Pure, thread-safe, allocation-free, never throws. Non-finite poses find nothing.

#include <span>

#include <Eigen/Geometry>

#include "server/geometry/bvh.h"
#include "server/geometry/types.h"

namespace hapticd::geometry {

struct MeshMeshContact {
  int triangle_a = -1;  // original index in mesh A
  int triangle_b = -1;  // original index in mesh B
  // The two triangles lie in one plane and overlap there; p0, p1 are then zero.
  bool coplanar = false;
  // Otherwise the intersection segment, in A's frame (p0 == p1 for a single point).
  Vector3 p0 = Vector3::Zero();
  Vector3 p1 = Vector3::Zero();
};

struct MeshMeshContacts {
  int count = 0;            // contacts written to the buffer
  int num_pairs = 0;        // intersecting pairs found, written or not
  bool truncated = false;   // num_pairs > buffer size: the first ones found were kept
};

// All intersecting (triangle of A, triangle of B) pairs. X_AB is the pose of B's frame
// in A's frame (p_A = X_AB * p_B); results are in A's frame. Pairs beyond out.size()
// are counted, not written. Mesh B's vertices are moved with X_AB in double precision,
// so under a non-identity pose a pair that touches exactly may be decided either way;
// under the identity the decision is exact.
MeshMeshContacts FindMeshMeshContacts(const MeshBvh& a, const MeshBvh& b,
                                      const Eigen::Isometry3d& X_AB,
                                      std::span<MeshMeshContact> out);

// True when any triangle of A touches any triangle of B (stops at the first).
bool MeshesIntersect(const MeshBvh& a, const MeshBvh& b, const Eigen::Isometry3d& X_AB);

}  // namespace hapticd::geometry
