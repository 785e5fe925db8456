#pragma once
// The control channel's batch point queries: ClosestPoint and FindContacts for many
// points against one scene snapshot, checked here and answered by query::FindClosestPoints
// and query::FindObjectContactsBatch. Off the real-time thread.
#include <cstddef>

#include "hapticd/v1/hapticd.pb.h"
#include "server/scene/scene_snapshot.h"

namespace hapticd::net {

// The most points one ClosestPointBatch, and centres one FindContactsBatch, may hold.
inline constexpr int kMaxBatchPoints = 1'000'000;
// The most contacts one FindContactsBatch may answer with (about 60 MB of reply).
inline constexpr std::size_t kMaxBatchContacts = 1'000'000;

// Each point's nearest surface point within batch.max_distance, in order. Throws
// RequestError naming the bad field (a ragged array, a non-finite point by its index,
// too many points, a bad max_distance).
v1::ClosestPoints FindClosestPointBatch(const scene::SceneSnapshot& scene, const v1::ClosestPointBatch& batch);

// Each sphere's contacts, in order, laid end to end (v1::ContactsBatch). Throws
// RequestError naming the bad field (a ragged array, a non-finite centre or a bad
// radius by its index, radii neither one nor one per centre, too many centres), or
// RESOURCE_EXHAUSTED when the answer would hold more than kMaxBatchContacts.
v1::ContactsBatch FindBatchContacts(const scene::SceneSnapshot& scene, const v1::FindContactsBatch& batch);

}  // namespace hapticd::net
