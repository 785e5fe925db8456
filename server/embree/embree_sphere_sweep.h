#pragma once

// The proxies' sweeps on an EmbreeMesh: a point (the god-object, r = 0) or a sphere (the
// finger proxy, r > 0) moving its centre a -> b, stopped where it first runs into a
// triangle, under the rules of server/geometry/sphere_sweep.h. Embree's BVH picks the
// candidate triangles and the same per-triangle sweep the native query makes
// (geometry::SweepSphereTriangle) decides on each, so the answers equal
// geometry::SweepSphereMesh(mesh.bvh(), a, b, r):
//  - a point sweeps as a ray (rtcIntersect1): every triangle the segment touches is a
//    candidate (see embree_mesh.h), and the best hit cuts the ray;
//  - a sphere sweeps as a point query (rtcPointQuery) around the middle of the motion,
//    of radius |b - a| / 2 plus the native sweep's reach (r and a slack) and the mesh's
//    guard: the swept capsule lies inside that ball, so every triangle it could touch is
//    a candidate.
//
// Points are in the mesh's frame. Thread-safe, allocation-free, never throw.

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

// First blocking contact of a sphere of radius r >= 0 moving its centre a -> b: the same
// hit, t, point, normal and feature as geometry::SweepSphereMesh(mesh.bvh(), a, b, r)
// (ties as above). r = 0 is SweepPointMesh. a == b, r < 0, or NaN or infinite input
// misses at once; a sweep beyond the trust bound (segment, or r above trust_bound()) is
// answered by the native BVH.
geometry::SphereSweepHit SweepSphereMesh(const EmbreeMesh& mesh, const geometry::Vector3& a,
                                         const geometry::Vector3& b, double r);

}  // namespace hapticd::embree
