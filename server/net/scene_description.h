#pragma once
// The control channel's GetScene: a snapshot described object by object (shape,
// representation, pose, material, motion), with the vertices and triangles of the
// meshes asked for, within a bound. Off the real-time thread.
#include <cstddef>
#include "hapticd/v1/hapticd.pb.h"
#include "server/scene/scene_snapshot.h"

namespace hapticd::net {

// The most mesh data one GetScene reply carries, counted as 24 bytes a vertex and 12 a
// triangle (its encoding takes no more: indices below 2^28 are varints of <= 4 bytes).
inline constexpr std::size_t kMaxMeshDataBytes = std::size_t{48} << 20;

// The scene as request asks for it. Throws RequestError: NOT_FOUND for a name in
// mesh_data_for that no object has (naming its index), BAD_REQUEST when both
// include_mesh_data and mesh_data_for are given, RESOURCE_EXHAUSTED when the meshes
// asked for hold more than max_mesh_data_bytes (naming how much they hold).
v1::SceneDescription DescribeScene(const scene::SceneSnapshot& scene, const v1::GetScene& request,
                                   std::size_t max_mesh_data_bytes = kMaxMeshDataBytes);

}  // namespace hapticd::net
