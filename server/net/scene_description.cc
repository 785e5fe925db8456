#include "server/net/scene_description.h"

#include <string_view>
#include <unordered_map>
#include <vector>

#include <fmt/format.h>

#include "server/net/proto_convert.h"
#include "server/net/request_error.h"

namespace hapticd::net {
namespace {

// What DescribeScene counts for a mesh's data.
std::size_t MeshDataBytes(const scene::SceneObject& object) {
  const auto& mesh = object.representation.mesh;
  if (!mesh) return 0;
  return 24 * static_cast<std::size_t>(mesh->num_vertices()) + 12 * static_cast<std::size_t>(mesh->num_triangles());
}

}  // namespace

v1::SceneDescription DescribeScene(const scene::SceneSnapshot& scene, const v1::GetScene& request,
                                   std::size_t max_mesh_data_bytes) {
  if (request.include_mesh_data() && request.mesh_data_for_size() > 0) {
    throw BadRequest(fmt::format("get_scene has include_mesh_data and {} names in mesh_data_for; give one "
                                 "(include_mesh_data: every mesh's data)",
                                 request.mesh_data_for_size()));
  }
  // which objects' mesh data goes in, and how much that is
  std::vector<char> with_data(static_cast<std::size_t>(scene.num_objects()), request.include_mesh_data());
  std::unordered_map<std::string_view, int> index_of_name;
  if (request.mesh_data_for_size() > 0) {
    for (int i = 0; i < scene.num_objects(); ++i) index_of_name.emplace(scene.object(i).name, i);
  }
  for (int i = 0; i < request.mesh_data_for_size(); ++i) {
    const std::string& name = request.mesh_data_for(i);
    const auto found = index_of_name.find(name);
    const int index = found == index_of_name.end() ? -1 : found->second;
    if (index < 0) {
      throw RequestError(v1::Error::CODE_NOT_FOUND,
                         fmt::format("get_scene.mesh_data_for[{}] is \"{}\"; the scene has no object of that name",
                                     i, name));
    }
    with_data[index] = 1;
  }
  std::size_t bytes = 0;
  int meshes = 0;
  for (int i = 0; i < scene.num_objects(); ++i) {
    if (!with_data[i] || MeshDataBytes(scene.object(i)) == 0) continue;
    bytes += MeshDataBytes(scene.object(i));
    ++meshes;
  }
  if (bytes > max_mesh_data_bytes) {
    throw RequestError(v1::Error::CODE_RESOURCE_EXHAUSTED,
                       fmt::format("get_scene asks for the vertices and triangles of {} meshes, {} bytes; one "
                                   "reply carries at most {} bytes of mesh data: name fewer in "
                                   "get_scene.mesh_data_for",
                                   meshes, bytes, max_mesh_data_bytes));
  }

  v1::SceneDescription description;
  description.set_version(scene.version());
  description.set_tolerance(scene.settings().tolerance);
  for (int i = 0; i < scene.num_objects(); ++i) {
    WriteObjectInfo(scene.object(i), description.add_objects(), with_data[i] != 0);
  }
  return description;
}

}  // namespace hapticd::net
