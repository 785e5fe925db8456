#pragma once
// The control channel's batch ray cast: many segments against a scene snapshot at once,
// checked here and answered by query::CastSegments (meshes on the Embree backend trace
// them in packets). Off the real-time thread.
#include "hapticd/v1/hapticd.pb.h"
#include "server/scene/scene_snapshot.h"

namespace hapticd::net {

// The first hit of each segment of batch, in order. Throws RequestError naming the bad
// field (uneven arrays, a non-finite value, a zero direction by its index, a bad
// max_distance). A segment that only touches a surface counts as a hit.
v1::RayHits CastRayBatch(const scene::SceneSnapshot& scene, const v1::RayCastBatch& batch);

}  // namespace hapticd::net
