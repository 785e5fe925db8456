#pragma once

// The two geometry queries a haptic tick makes near a surface, timed and checked against
// the analytic truth for each representation hapticd offers:
//   closest point: error ||p - answer| - |p - true closest point|| (m), the error of the
//     unsigned distance to the surface (what every peer answers; the closest point's
//     own position errs more, sideways, by the offset times the facets' normal error);
//   first hit of a segment: error |answer - true first hit| (m); a segment the
//     representation misses counts |q - true hit|, how far a proxy would pass the
//     surface, and is counted in misses.
// Primitive and hull are answered by the force library's shape queries (what a tick
// calls: force::ProbeShape, force::SweepSphereShape with radius 0); a mesh by the
// geometry core's BVH (native), the Embree backend (embree: the same exact answers), or
// raw float Embree (embree_raw, first hit only: unconfirmed, for comparison).

#include <memory>
#include <vector>

#include "bench/speed_accuracy_io.h"
#include "bench/speed_accuracy_surfaces.h"
#include "server/embree/embree_mesh.h"
#include "server/embree/embree_triangle_scene.h"
#include "server/geometry/bvh.h"
#include "server/scene/shape.h"

namespace hapticd::bench {

// Rows for the analytic sphere primitive (SphereShape of the surface's radius).
std::vector<ResultRow> MeasurePrimitiveQueries(const AnalyticSurface& surface, const QueryInputs& inputs,
                                               const TimingOptions& timing);

// Rows for the hull of a tessellation (shape: a scene::ConvexShape).
std::vector<ResultRow> MeasureHullQueries(const AnalyticSurface& surface, int level,
                                          const scene::ConvexShape& hull, const QueryInputs& inputs,
                                          const TimingOptions& timing);

// Rows for a tessellation: native and Embree backend (both queries), raw Embree
// (first hit).
struct MeshBackends {
  std::shared_ptr<const geometry::MeshBvh> bvh;
  std::shared_ptr<const embree::EmbreeMesh> embree;
  std::shared_ptr<const embree::EmbreeTriangleScene> embree_raw;
};
std::vector<ResultRow> MeasureMeshQueries(const AnalyticSurface& surface, int level,
                                          const MeshBackends& mesh, const QueryInputs& inputs,
                                          const TimingOptions& timing);

}  // namespace hapticd::bench
