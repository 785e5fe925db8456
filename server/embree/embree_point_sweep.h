#pragma once

// The god-object's sweep on an EmbreeMesh: a point (r = 0) moving a -> b, stopped where
// it first runs into a triangle, under the rules of server/geometry/sphere_sweep.h.
// Embree's traversal picks the candidate triangles (every triangle the segment touches,
// see embree_mesh.h); on each, the same per-triangle sweep the native query makes
// (geometry::SweepSphereTriangle with r = 0) decides, so the answer equals
// geometry::SweepSphereMesh(mesh.bvh(), a, b, 0).
//
// Points are in the mesh's frame. Thread-safe, allocation-free, never throws.

#include "server/embree/embree_mesh.h"
#include "server/geometry/sphere_sweep.h"
#include "server/geometry/types.h"

namespace hapticd::embree {

// First blocking contact of a point moving a -> b: the exact segment test, both sides of
// a triangle block; a start exactly on a triangle's plane counts as its front side (it
// blocks at t = 0 only when b is strictly behind it); a segment in a triangle's plane
// never hits that triangle. Same hit, t, point, normal and feature as
// geometry::SweepSphereMesh(mesh.bvh(), a, b, 0); where two triangles block at exactly
// the same t, either may be reported (with its own normal and feature), as natively.
// a == b, or NaN or infinite input, misses at once; a sweep beyond the mesh's trust
// bound is answered by the native BVH.
geometry::SphereSweepHit SweepPointMesh(const EmbreeMesh& mesh, const geometry::Vector3& a,
                                        const geometry::Vector3& b);

}  // namespace hapticd::embree
