#pragma once
// The control channel's batch ray cast: many segments against a scene snapshot at once,
// checked here and answered by query::CastSegments (meshes on the Embree backend trace
// them in packets). Off the real-time thread.
#include "hapticd/v1/hapticd.pb.h"
#include "server/scene/scene_snapshot.h"

namespace hapticd::net {

// The most segments one RayCastBatch may hold.
inline constexpr int kMaxRaySegments = 1'000'000;

// The first hit of each segment of batch, in order: one per direction, from its own
// origin or from the batch's single origin (origins holding 3 values). Throws
// RequestError naming the bad field (uneven arrays, a non-finite value, a zero
// direction by its index, a bad max_distance, over kMaxRaySegments). A segment that only
// touches a surface counts as a hit.
v1::RayHits CastRayBatch(const scene::SceneSnapshot& scene, const v1::RayCastBatch& batch);

}  // namespace hapticd::net
