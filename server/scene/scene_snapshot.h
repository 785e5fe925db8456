#pragma once

// An immutable scene: the objects a tick renders against. A tick reads one snapshot
// from start to end; edits build a new one (scene_builder.h) and publish it
// (snapshot_publisher.h). Everything here is const and safe to read from any thread.

#include <cstdint>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "server/scene/object_index.h"
#include "server/scene/object_list.h"
#include "server/scene/scene_limits.h"
#include "server/scene/scene_object.h"

namespace hapticd::scene {

struct SceneSettings {
  // How far (m) a cheaper representation of a mesh may be from the mesh.
  double tolerance = 1e-4;
  // The backend of the objects kept as meshes, unless an object names its own.
  RayBackend ray_backend = RayBackend::kNative;
  SceneBudgets budgets;
};

// The kinematic objects' indices, ascending: kept by the builder, shared by snapshots.
// Points to a non-const vector (the builder's copy-on-write relies on it).
using KinematicList = std::shared_ptr<const std::vector<int>>;

class SceneSnapshot {
 public:
  // index: the broad phase over objects, kinematic: the kinematic objects (the builder
  // keeps both up to date).
  SceneSnapshot(ObjectList objects, ObjectIndex index, KinematicList kinematic, SceneSettings settings,
                uint64_t version);
  // Copies the objects and builds their index (for tests).
  SceneSnapshot(const std::vector<SceneObject>& objects, SceneSettings settings, uint64_t version);

  // Increases with every published edit.
  uint64_t version() const { return version_; }
  const SceneSettings& settings() const { return settings_; }
  int num_objects() const { return objects_.size(); }
  const SceneObject& object(int i) const { return *objects_[i]; }
  // Index of the object named name, or -1: a linear scan (the builder, which every
  // edit goes through, keeps a hash index).
  int FindObject(std::string_view name) const;
  // The kinematic objects' indices, ascending.
  std::span<const int> kinematic_objects() const { return *kinematic_; }

  // Calls visit(i) for each object i whose bounds_W overlap box, each once, in no
  // particular order (unbounded objects always), until a visit returns false.
  // Real-time safe.
  template <typename Visit>
  void ForEachObjectNear(const geometry::Aabb& box, Visit visit) const {
    index_.ForEachNear(box, visit);
  }
  // The same, for a caller that asks about nearly the same place each time (an avatar):
  // cache remembers the region (object_index.h).
  template <typename Visit>
  void ForEachObjectNear(const geometry::Aabb& box, NearCache& cache, Visit visit) const {
    index_.ForEachNear(box, cache, visit);
  }
  // The same objects as indices in scene order (allocates: for the control thread).
  std::vector<int> ObjectsNear(const geometry::Aabb& box) const;

 private:
  ObjectList objects_;
  ObjectIndex index_;
  KinematicList kinematic_;
  SceneSettings settings_;
  uint64_t version_;
};

}  // namespace hapticd::scene
