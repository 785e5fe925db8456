#include "server/scene/scene_snapshot.h"

#include <algorithm>
#include <utility>

namespace hapticd::scene {

namespace {

ObjectList Share(const std::vector<SceneObject>& objects) {
  ObjectList shared;
  for (const SceneObject& object : objects) shared.PushBack(std::make_shared<SceneObject>(object));
  return shared;
}

ObjectIndex IndexOf(const std::vector<SceneObject>& objects) {
  ObjectIndex index;
  for (int i = 0; i < static_cast<int>(objects.size()); ++i) {
    index.Insert(i, objects[i].bounds_W, objects[i].motion == Motion::kKinematic);
  }
  return index;
}

KinematicList KinematicOf(const std::vector<SceneObject>& objects) {
  auto kinematic = std::make_shared<std::vector<int>>();
  for (int i = 0; i < static_cast<int>(objects.size()); ++i) {
    if (objects[i].motion == Motion::kKinematic) kinematic->push_back(i);
  }
  return kinematic;
}

}  // namespace

SceneSnapshot::SceneSnapshot(ObjectList objects, ObjectIndex index, KinematicList kinematic,
                             SceneSettings settings, uint64_t version)
    : objects_(std::move(objects)),
      index_(std::move(index)),
      kinematic_(std::move(kinematic)),
      settings_(settings),
      version_(version) {}

SceneSnapshot::SceneSnapshot(const std::vector<SceneObject>& objects, SceneSettings settings, uint64_t version)
    : SceneSnapshot(Share(objects), IndexOf(objects), KinematicOf(objects), settings, version) {}

int SceneSnapshot::FindObject(std::string_view name) const {
  for (int i = 0; i < num_objects(); ++i) {
    if (objects_[i]->name == name) return i;
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
