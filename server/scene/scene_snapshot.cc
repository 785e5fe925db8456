#include "server/scene/scene_snapshot.h"

#include <algorithm>
#include <utility>

namespace hapticd::scene {

namespace {

SharedObjects Share(const std::vector<SceneObject>& objects) {
  SharedObjects shared;
  for (const SceneObject& object : objects) shared.push_back(std::make_shared<SceneObject>(object));
  return shared;
}

ObjectIndex IndexOf(const std::vector<SceneObject>& objects) {
  ObjectIndex index;
  for (int i = 0; i < static_cast<int>(objects.size()); ++i) index.Insert(i, objects[i].bounds_W);
  return index;
}

}  // namespace

SceneSnapshot::SceneSnapshot(SharedObjects objects, ObjectIndex index, SceneSettings settings, uint64_t version)
    : objects_(std::move(objects)), index_(std::move(index)), settings_(settings), version_(version) {
  for (int i = 0; i < num_objects(); ++i) {
    if (objects_[i]->motion == Motion::kKinematic) kinematic_.push_back(i);
  }
}

SceneSnapshot::SceneSnapshot(const std::vector<SceneObject>& objects, SceneSettings settings, uint64_t version)
    : SceneSnapshot(Share(objects), IndexOf(objects), settings, version) {}

int FindObjectNamed(const SharedObjects& objects, std::string_view name) {
  for (int i = 0; i < static_cast<int>(objects.size()); ++i) {
    if (objects[i]->name == name) return i;
  }
  return -1;
}

std::vector<int> SceneSnapshot::ObjectsNear(const geometry::Aabb& box) const {
  std::vector<int> near;
  ForEachObjectNear(box, [&](int i) {
    near.push_back(i);
    return true;
  });
  std::sort(near.begin(), near.end());
  return near;
}

}  // namespace hapticd::scene
