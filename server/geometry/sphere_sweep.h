#pragma once

// Swept-sphere queries for the proxies of the rendering core: the god-object (a point,
// r = 0) and the finger proxy (a sphere of radius r > 0) move their centre from a to b
// and stop where they first run into a triangle.
//
// Theory of operation. Let c(t) = a + t (b - a), t in [0, 1], and D(t) the distance from
// c(t) to the closed triangle; D is convex in t. A proxy rests ON surfaces, at D ~ r
// within rounding, and slides along them, so a contact counts only when the motion
// goes INTO the triangle:
//  - r > 0: a triangle blocks the sweep when D falls to r - skin or below while
//    decreasing (skin = CalcSphereSweepSkin(a, b, r), about 1e-9 of the coordinates).
//    The hit is reported where D first reaches r: t = 0 when D(0) <= r already. So
//    motion away from or along a touched triangle never blocks (a sphere resting on a
//    plane made of many triangles slides across their shared edges and vertices), a
//    grazing pass that dips less than skin below r does not block either, and a sweep
//    never takes the sphere more than skin into any triangle. "Decreasing" where the
//    centre lies on the triangle (D = 0) is taken on its front side (the side the
//    right-handed normal points to): the motion must go behind it.
//  - r = 0: the exact, watertight segment test (IntersectSegmentTriangleWatertight), so
//    a point aimed through an edge or vertex shared by triangles of a closed mesh hits
//    one of them. Both sides of a triangle block. A start exactly on a triangle's plane
//    counts as its front side: it blocks at t = 0 only when b lies strictly behind it.
//    A segment in a triangle's plane never hits it (its neighbours may be hit). So a
//    point exactly on a closed surface slides freely across a flat region, but past a
//    convex edge it crosses the faces beyond it from behind and is stopped there: a
//    point proxy should rest a little off the surface.
//  - 0 < r <= 1e-12 of the coordinates' magnitude is swept as a point (r = 0): below
//    that, rounding would be larger than the sphere.
//  - a == b, r < 0, or any NaN or infinite input: a miss, at once.
//
// r > 0 is decided per feature, on the boundary of the triangle swelled by the radius:
// the face's plane offset by r towards the centre (where the contact projects into the
// triangle), the three edge cylinders and the three vertex spheres; the first is the
// hit. Every decision is made on the double-precision triangle; all points are in one
// frame (the mesh's), in its units. Pure, thread-safe, allocation-free, never throws.

#include <span>

#include "server/geometry/aabb.h"
#include "server/geometry/bvh.h"
#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/types.h"

namespace hapticd::geometry {

struct SphereSweepHit {
  bool hit = false;
  double t = 0;  // first contact: centre = a + t (b - a), t in [0, 1]
  // The point of the triangle closest to the centre at contact (the centre itself for
  // r = 0), and the feature it lies on (for r = 0: the feature the segment crosses).
  Vector3 point = Vector3::Zero();
  // Unit, from the surface towards the centre at contact: on a face the face normal
  // turned to the centre's side (the front side when the centre is in the plane), on
  // an edge or vertex (centre - point) / |centre - point|. For r = 0 the face normal
  // turned towards a.
  Vector3 normal = Vector3::UnitZ();
  int triangle = -1;  // original mesh index (SweepSphereMesh), -1 for a lone triangle
  TriangleFeature feature = TriangleFeature::kFace;
};

// The depth a sweep of radius r from a to b may sink into a triangle without being
// blocked: min(r / 2, 1e-9 (r + max |a_i|, |b_i|)); 0 for r swept as a point, or for
// non-finite input. Far above the rounding of the coordinates, far below what a hand
// can feel.
double CalcSphereSweepSkin(const Vector3& a, const Vector3& b, double r);

// How far from the segment a -> b a sweep of radius r can touch anything: r (0 for r
// swept as a point) plus 1e-12 of the coordinates' magnitude. SweepSphereMesh skips what
// lies farther; 0 for input that misses at once.
double CalcSphereSweepReach(const Vector3& a, const Vector3& b, double r);

// First contact of a sphere of radius r >= 0, its centre moving a -> b, with the closed
// triangle tri, under the rules above. A degenerate (zero-area) triangle has no face:
// r > 0 still meets its edges and corners, r = 0 misses it.
SphereSweepHit SweepSphereTriangle(const Triangle& tri, const Vector3& a, const Vector3& b,
                                   double r);

// The same against every non-degenerate triangle of a mesh, through its BVH (boxes grown
// by r and the ball around the sweep prune, nearest first, cut at the best hit so far;
// the traversal of FindFirstSegmentHit): the earliest of the triangles' hits,
// any one of them where several tie. Equals the minimum of SweepSphereTriangle over the
// mesh's triangles, with triangle set to the original index.
SphereSweepHit SweepSphereMesh(const MeshBvh& bvh, const Vector3& a, const Vector3& b, double r);

// A mesh triangle made ready to be swept many times (SweepSphereTriangles): what
// SweepSphereMesh computes of each triangle it meets, computed once.
struct PreparedTriangle {
  Triangle triangle;
  Aabb box;                 // Aabb::OfTriangle(triangle)
  Vector3 centroid = Vector3::Zero();
  double bounding_radius = 0;  // of the sphere about centroid that holds the triangle
  Vector3 normal = Vector3::Zero();  // unit, right-handed; zero for no area
  int index = -1;           // original mesh index
};

PreparedTriangle PrepareTriangle(const Triangle& triangle, int index);

// Whether the prepared triangle lies farther than limit from p, by the lower bound
// SweepSphereTriangles passes triangles over with: p's height over the triangle's plane
// beside its distance within the plane from the bounding circle. Exact but for a few
// ulps of the squares (callers keep a slack above that).
bool LiesFartherThan(const PreparedTriangle& triangle, const Vector3& p, double limit);

// The triangles of bvh (its non-degenerate ones) that may lie within region.radius
// (>= 0) of the segment region.p0 -> region.p1 (a ball when they are equal), prepared, in
// no particular order: writes them to out and returns how many there are, or
// out.size() + 1 as soon as more are found than out holds (the traversal stops there).
// Every triangle left out is farther than the radius from the segment: it was passed
// over by a lower bound of its distance (its box's from the segment's box, the disc's
// about its BVH child (BvhDiscs), or its height over its plane beside its bounding
// circle, as SweepSphereTriangles bounds a sweep).
// Charges the work meter like the BVH queries (one unit per node opened and per
// primitive tested); non-finite input finds nothing.
int GatherMeshTriangles(const MeshBvh& bvh, const Capsule& region, std::span<PreparedTriangle> out);

// SweepSphereMesh over the given triangles instead of a whole mesh, with its decisions
// bit for bit: the earliest of their hits, the first of them in the span where several
// tie (triangle: its index). Triangles the sweep cannot come within reach of are passed
// over by a bound tighter than the mesh sweep's (the segment's height over the
// triangle's plane and its distance within that plane from the triangle's bounding
// circle), so that a sphere sliding over a dense surface tests few exactly. Charges one
// work unit per triangle tested exactly and one per eight passed over.
SphereSweepHit SweepSphereTriangles(std::span<const PreparedTriangle> triangles, const Vector3& a,
                                    const Vector3& b, double r);

}  // namespace hapticd::geometry
