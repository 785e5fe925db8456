#include "server/scene/scene_snapshot.h"

#include <utility>

namespace hapticd::scene {

SceneSnapshot::SceneSnapshot(std::vector<SceneObject> objects, SceneSettings settings,
                             uint64_t version)
    : objects_(std::move(objects)), settings_(settings), version_(version) {}

int SceneSnapshot::FindObject(std::string_view name) const {
  // scenes hold tens of objects: a linear scan beats an index
  for (int i = 0; i < num_objects(); ++i) {
    if (objects_[i].name == name) return i;
  }
  return -1;
}

}  // namespace hapticd::scene
