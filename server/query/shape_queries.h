#pragma once

// What is asked of one shape, in the shape's body frame B: where is the nearest surface
// (and how deep is a point inside), where does a moving sphere first touch it, which
// pieces of its surface lie near a point. One function per question, dispatched through
// one table row per representation (and, for meshes, per backend: mesh_backends.h).

#include <span>

#include "server/geometry/mesh_queries.h"
#include "server/query/gathered_mesh.h"
#include "server/scene/shape.h"

namespace hapticd::query {

using geometry::Vector3;

struct ShapeProbe {
  bool found = false;          // false: nothing within max_distance (or non-finite input)
  double signed_distance = 0;  // of p from the surface: < 0 inside the solid, m
  Vector3 point_B = Vector3::Zero();   // nearest surface point
  Vector3 normal_B = Vector3::UnitZ(); // unit outward normal there (from the solid towards p
                                       // when outside)
  int triangle = -1;                   // meshes: the triangle holding point_B
};

// Nearest surface point of shape to p_B and p's signed distance. A closed mesh is a
// solid like the primitives. An open mesh (geometry::TriangleMesh::is_closed() false)
// is a surface with no inside: its signed distance is the unsigned distance (never
// negative, so nothing is ever inside it and a point avatar never penetrates it), and
// normal_B points from the surface towards p (the pseudo-normal where p is on it). Only
// surfaces within max_distance (>= 0) are looked for. Real-time safe.
ShapeProbe ProbeShape(const scene::Shape& shape, const Vector3& p_B, double max_distance);

struct ShapeSweep {
  bool hit = false;
  double t = 0;                         // centre at contact = a + t (b - a), t in [0, 1]
  Vector3 point_B = Vector3::Zero();    // contact point on the surface
  Vector3 normal_B = Vector3::UnitZ();  // unit, from the surface towards the centre
  int triangle = -1;                    // meshes: the touched triangle
};

// First contact of a sphere of radius r >= 0 (0: a point) whose centre moves a_B -> b_B.
// A surface the sphere already touches at t = 0 counts only if the motion goes into it,
// so a proxy resting on a surface can slide along it. NaN or infinite input (r
// included), r < 0 or a_B == b_B: a miss. Real-time safe. The primitives' and hulls'
// answers are geometry::SweepSphereSphere's and SweepSphereConvex's (sphere_convex_sweep.h).
//
// A point (r = 0, a ray cast) follows one rule in every representation: it reports the
// first surface crossing along a_B -> b_B, whichever side it comes from. So a point
// starting inside a solid (primitive, hull or closed mesh) hits where it leaves it,
// with normal_B turned back towards a_B (into the solid), and misses if b_B is inside
// too; a point starting on the surface hits at t = 0 only when it moves into the
// solid. Open meshes block from both sides like any surface. For primitives and hulls
// "on the surface" means within 1e-10 m of it (the sweeps' touching tolerance), and
// the crossings they report are within that of the exact one.
ShapeSweep SweepSphereShape(const scene::Shape& shape, const Vector3& a_B, const Vector3& b_B,
                            double r);

// SweepSphereShape, asking a mesh's nearest triangle and sweep of the triangles gathered
// near the sweep (gathered_mesh.h) where they decide them: the same first contact (of
// triangles touched at the same t, it may name another). Other shapes ignore near.
ShapeSweep SweepSphereShape(const scene::Shape& shape, const Vector3& a_B, const Vector3& b_B, double r,
                            const GatheredMesh& near);

// out[i] = SweepSphereShape(shape, a_B[i], b_B[i], 0) for the first min(sizes) segments
// (a ray batch): a mesh's backend traces them together (Embree in packets). Stops early
// once the thread's work meter is spent (the rest of out left as it was).
void SweepPointsShape(const scene::Shape& shape, std::span<const Vector3> a_B, std::span<const Vector3> b_B,
                      std::span<ShapeSweep> out);

// The pieces of the shape's surface within radius (finite, >= 0) of p_B: a primitive,
// plane or hull is one piece (triangle -1, its nearest point and outward normal, depth =
// radius - signed distance, so a point inside has depth > radius); a mesh's pieces are
// its triangles (geometry::FindSphereMeshContacts: unsigned distances). Writes as many as
// out holds (a mesh keeps its deepest) and returns how many there are. Non-finite input
// finds nothing. Real-time safe.
int FindShapeFeatures(const scene::Shape& shape, const Vector3& p_B, double radius,
                      std::span<geometry::SphereMeshContact> out);

// The normal to render at a contact: the interpolated vertex normal of a mesh triangle
// at point_B (Phong-style force shading), or normal_B itself for every other shape.
Vector3 CalcShadingNormal(const scene::Shape& shape, int triangle, const Vector3& point_B,
                          const Vector3& normal_B);

}  // namespace hapticd::query
