#include "server/scene/scene_snapshot.h"

#include <utility>

namespace hapticd::scene {

namespace {

ObjectIndex IndexOf(const std::vector<SceneObject>& objects) {
  ObjectIndex index;
  for (int i = 0; i < static_cast<int>(objects.size()); ++i) index.Insert(i, objects[i].bounds_W);
  return index;
}

}  // namespace

SceneSnapshot::SceneSnapshot(std::vector<SceneObject> objects, ObjectIndex index, SceneSettings settings,
                             uint64_t version)
    : objects_(std::move(objects)), index_(std::move(index)), settings_(settings), version_(version) {
  for (int i = 0; i < num_objects(); ++i) {
    if (objects_[i].motion == Motion::kKinematic) kinematic_.push_back(i);
  }
}

SceneSnapshot::SceneSnapshot(std::vector<SceneObject> objects, SceneSettings settings, uint64_t version)
    : SceneSnapshot(objects, IndexOf(objects), settings, version) {}

int SceneSnapshot::FindObject(std::string_view name) const {
  // scenes hold tens of objects: a linear scan beats an index
  for (int i = 0; i < num_objects(); ++i) {
    if (objects_[i].name == name) return i;
  }
  return -1;
}

}  // namespace hapticd::scene
