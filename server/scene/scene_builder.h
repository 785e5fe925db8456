#pragma once

// Builds scene snapshots off the real-time thread. This is the scene's validation
// boundary: a bad edit throws SceneError with a message that names the field and value
// ("objects[plate].shape.half_extents[2] is -0.001; it must be a finite number > 0"),
// and leaves the builder as it was.

#include <array>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unordered_map>
#include <variant>
#include <vector>

#include "server/geometry/triangle_mesh.h"
#include "server/scene/scene_snapshot.h"

namespace hapticd::embree {
class EmbreeDevice;
}  // namespace hapticd::embree

namespace hapticd::scene {

class SceneError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// Shapes as a client describes them (before validation and representation choice): the
// primitives as they are stored (shape.h, validated here), point sets and meshes raw.
struct ConvexSpec {
  std::vector<Vector3> points;  // in B; their hull must be 3-dimensional
};
struct MeshSpec {
  std::vector<Vector3> vertices;  // in B
  std::vector<std::array<int, 3>> triangles;
  Representation pin = Representation::kAuto;
};
using ShapeSpec = std::variant<SphereShape, BoxShape, CapsuleShape, PlaneShape, ConvexSpec, MeshSpec>;

struct ObjectSpec {
  std::string name;  // unique in the scene, non-empty
  ShapeSpec shape;
  // Pose of the frame the shape is given in (a mesh's frame M; the object's stored X_WB
  // is then X_WM X_MS, where its representation sits). Rotation orthonormal and
  // right-handed (within 1e-6).
  Pose X_WB;
  Material material;
  Motion motion = Motion::kStatic;
  Vector3 v_WB = Vector3::Zero();  // kinematic only
  Vector3 w_WB = Vector3::Zero();
  // A mesh's backend, when not the scene's (SceneSettings::ray_backend).
  std::optional<RayBackend> ray_backend;
};

class SceneBuilder {
 public:
  explicit SceneBuilder(SceneSettings settings = {});

  // Validates spec, chooses a mesh's representation, builds hulls and BVHs. Returns the
  // new object.
  const SceneObject& Add(const ObjectSpec& spec);
  // Replaces the object named spec.name (which must exist) with spec.
  const SceneObject& Update(const ObjectSpec& spec);
  void Remove(std::string_view name);
  void SetMaterial(std::string_view name, const Material& material);
  // Moves a kinematic object (a static one is refused) and sets its velocity. X_WB and
  // v_WB are those of the frame its spec was given in, as in ObjectSpec.
  void MoveKinematic(std::string_view name, const Pose& X_WB, const Vector3& v_WB,
                     const Vector3& w_WB);
  // Moves every kinematic object by its velocity over dt (s, >= 0): the exact rigid
  // motion at constant v_WB and w_WB of the frame its spec was given in. Returns
  // whether anything moved (some kinematic object has a non-zero velocity).
  bool AdvanceKinematic(double dt);
  // Whether some kinematic object has a non-zero velocity (AdvanceKinematic would move it).
  bool HasMovingObjects() const;

  const SceneSettings& settings() const { return settings_; }
  int num_objects() const { return objects_.size(); }
  // Index of the object named name, or -1 (a hash lookup).
  int FindObject(std::string_view name) const;
  // The material of the object at index (in [0, num_objects())).
  const Material& material(int index) const { return objects_[index]->material; }
  // A snapshot of the objects so far (the geometry is shared, not copied).
  std::shared_ptr<const SceneSnapshot> Build(uint64_t version) const;

 private:
  // The index of the object named name; SceneError when there is none.
  int IndexOrThrow(std::string_view name) const;
  // Object index, to be changed: copied first when a snapshot shares it.
  SceneObject& Writable(int index);
  // The kinematic list, to be changed: copied first when a snapshot shares it.
  std::vector<int>& WritableKinematic();
  // Puts a mesh object on the Embree backend when its spec or the scene asks for it.
  void AttachRayBackend(const ObjectSpec& spec, SceneObject& object);

  SceneSettings settings_;
  // Shared with the snapshots built from them: an edit replaces or copies the objects it
  // changes and leaves the others shared.
  ObjectList objects_;
  // The triangles its objects keep as meshes, together (the triangle budget's count).
  std::size_t kept_triangles_ = 0;
  // Each object's index by name.
  struct NameHash {
    using is_transparent = void;
    size_t operator()(std::string_view name) const { return std::hash<std::string_view>{}(name); }
  };
  std::unordered_map<std::string, int, NameHash, std::equal_to<>> index_of_name_;
  // The broad phase over objects_, kept up to date by every edit.
  ObjectIndex index_;
  // The kinematic objects' indices, ascending (shared with the snapshots).
  KinematicList kinematic_ = std::make_shared<std::vector<int>>();
  // Created when the first mesh asks for the Embree backend; shared by its meshes.
  std::shared_ptr<const embree::EmbreeDevice> embree_device_;
};

}  // namespace hapticd::scene
