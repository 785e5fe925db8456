#pragma once

// Segments aimed exactly through the vertices and edge midpoints of a mesh, from
// outside to just inside: the inputs on which single-precision ray casting leaks (the
// ray slips between the triangles around the feature). For the leak-rate program and
// the tests that show the backend does not leak.

#include <random>
#include <vector>

#include "server/geometry/mesh_queries.h"
#include "server/geometry/triangle_mesh.h"
#include "server/geometry/types.h"

namespace hapticd::embree {

struct AimedSegment {
  geometry::Vector3 p = geometry::Vector3::Zero();  // outside the surface
  geometry::Vector3 q = geometry::Vector3::Zero();  // just past the aimed-at feature
};

struct AimedSegmentOptions {
  int per_target = 4;        // segments through each vertex and each edge midpoint
  double reach = 0.05;       // |p - target| / mesh size
  double depth = 1e-3;       // |q - target| / mesh size
  double max_angle = 1.2;    // largest angle (rad) between p - target and the feature's
                             // pseudo-normal
};

// For each vertex used by a non-degenerate triangle and each undirected edge (by vertex
// index) of the mesh, options.per_target segments through it: p = target + reach s u,
// q = target - depth s u (s = mesh size), u uniform over the directions within
// max_angle of the feature's pseudo-normal, drawn from rng. Vertices first, then edges.
std::vector<AimedSegment> MakeAimedSegments(const geometry::TriangleMesh& mesh,
                                            const AimedSegmentOptions& options,
                                            std::mt19937_64& rng);

// How far (m) a float answer may stray along p -> q by rounding alone: 2^-16 of
// |p|_inf + |q - p|_inf (256 float ulps of the coordinates).
double FloatRoundingSlack(const geometry::Vector3& p, const geometry::Vector3& q);

// A leak: the exact answer hits p -> q, and the answer under test misses, or hits further
// on than the exact first hit by more than FloatRoundingSlack: a proxy would pass the
// first surface.
bool IsLeak(const geometry::SegmentMeshHit& exact, const geometry::SegmentMeshHit& answer,
            const geometry::Vector3& p, const geometry::Vector3& q);

}  // namespace hapticd::embree
