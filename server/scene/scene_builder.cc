#include "server/scene/scene_builder.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>

#include "server/embree/embree_device.h"
#include "server/embree/embree_mesh.h"
#include "server/geometry/convex_hull.h"
#include "server/scene/shape_digest.h"
#include "server/scene/value_text.h"

namespace hapticd::scene {
namespace {

// How far R^T R may be from the identity (Frobenius norm).
constexpr double kRotationTolerance = 1e-6;

std::string ObjectField(std::string_view name) { return "objects[" + std::string(name) + "]"; }

using L = SceneLimits;

// "<field> is <value>; it must be a finite number > 0" unless value is one.
void RequirePositive(double value, const std::string& field) {
  if (!(value > 0) || !std::isfinite(value)) {
    throw SceneError(field + " is " + FormatExact(value) + "; it must be a finite number > 0");
  }
}

// A size: in (0, SceneLimits::kMaxSize] (from 0 when zero is allowed).
void RequireSize(double value, const std::string& field, bool zero_allowed = false) {
  if (!(zero_allowed ? value >= 0 : value > 0) || !(value <= L::kMaxSize)) {
    throw SceneError(field + " is " + FormatExact(value) + "; it must be in " + (zero_allowed ? "[" : "(") +
                     "0, " + FormatExact(L::kMaxSize) + "] m");
  }
}

void RequireFinite(const Vector3& v, const std::string& field) {
  if (!v.allFinite()) throw SceneError(field + " is " + FormatExact(v) + "; it must be finite");
}

// Finite, and no farther than bound along any axis.
void RequireWithin(const Vector3& v, double bound, const std::string& field, const char* unit) {
  RequireFinite(v, field);
  if (v.cwiseAbs().maxCoeff() > bound) {
    throw SceneError(field + " is " + FormatExact(v) + "; each coordinate must be within +-" +
                     FormatExact(bound) + " " + unit);
  }
}

// A name: non-empty, within the budget's bytes, no control characters (names are
// echoed in errors and logs).
void ValidateName(const std::string& name, const SceneBudgets& budgets) {
  if (name.empty()) throw SceneError("objects[] name is empty");
  if (name.size() > budgets.max_name_bytes) {
    throw SceneError("objects[" + name.substr(0, 32) + "...].name has " + std::to_string(name.size()) +
                     " bytes; the budget is " + std::to_string(budgets.max_name_bytes) + " (max_name_bytes)");
  }
  for (const char c : name) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
      throw SceneError("objects[] name has the control character " +
                       std::to_string(static_cast<unsigned char>(c)) + "; names must be printable");
    }
  }
}

// A rigid pose: finite, orthonormal within kRotationTolerance, right-handed.
void ValidatePose(const Pose& X, const std::string& object) {
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      if (!std::isfinite(X.rotation(i, j))) {
        throw SceneError(object + ".rotation[" + std::to_string(i) + "][" + std::to_string(j) +
                         "] is " + FormatExact(X.rotation(i, j)) + "; it must be finite");
      }
    }
  }
  RequireWithin(X.translation, L::kMaxCoordinate, object + ".translation", "m");
  const double deviation = (X.rotation.transpose() * X.rotation - Matrix3::Identity()).norm();
  if (deviation > kRotationTolerance) {
    throw SceneError(object + ".rotation is not a rotation (|R^T R - I| = " +
                     FormatShort(deviation) + ")");
  }
  // orthonormal with det -1: a mirror image, which would turn every normal inside out
  const double det = X.rotation.determinant();
  if (det < 0) {
    throw SceneError(object + ".rotation is a reflection (det R = " + FormatShort(det) +
                     "); it must be right-handed");
  }
}

// Velocities: finite, and zero unless the object is kinematic.
void ValidateVelocities(Motion motion, const Vector3& v_WB, const Vector3& w_WB,
                        const std::string& object) {
  RequireFinite(v_WB, object + ".v_WB");
  RequireFinite(w_WB, object + ".w_WB");
  if (!(v_WB.norm() <= L::kMaxSpeed)) {
    throw SceneError(object + ".v_WB is " + FormatExact(v_WB) + "; its speed must be at most " +
                     FormatExact(L::kMaxSpeed) + " m/s");
  }
  if (!(w_WB.norm() <= L::kMaxAngularSpeed)) {
    throw SceneError(object + ".w_WB is " + FormatExact(w_WB) + "; its rate must be at most " +
                     FormatExact(L::kMaxAngularSpeed) + " rad/s");
  }
  if (motion == Motion::kKinematic) return;
  for (const auto& [v, name] : {std::pair{&v_WB, ".v_WB"}, std::pair{&w_WB, ".w_WB"}}) {
    if (!v->isZero(0)) {
      throw SceneError(object + name + " is " + FormatExact(*v) +
                       "; a static object cannot move (make it kinematic)");
    }
  }
}

// X_AC from X_AB and X_BC.
Pose Compose(const Pose& X_AB, const Pose& X_BC) {
  return {X_AB.rotation * X_BC.rotation, X_AB.ToWorld(X_BC.translation)};
}

// A convex shape: within the budget, finite points of bounded size whose hull is a solid.
ConvexShape MakeConvex(const ConvexSpec& spec, const std::string& field, const SceneBudgets& budgets) {
  if (spec.points.empty()) {
    throw SceneError(field + ".points is empty; a convex shape needs at least 4 points");
  }
  if (spec.points.size() > budgets.max_points_per_convex) {
    throw SceneError(field + ".points has " + std::to_string(spec.points.size()) + " points; the budget is " +
                     std::to_string(budgets.max_points_per_convex) + " (max_points_per_convex)");
  }
  for (size_t i = 0; i < spec.points.size(); ++i) {
    RequireWithin(spec.points[i], L::kMaxCoordinate, field + ".points[" + std::to_string(i) + "]", "m");
  }
  auto hull = std::make_shared<geometry::ConvexHull>(geometry::BuildConvexHull(spec.points));
  // flat or thinner: no inside to push a proxy out of
  if (hull->dimension != 3) {
    const char* what = hull->dimension == 2   ? "are coplanar"
                       : hull->dimension == 1 ? "are collinear"
                                              : "coincide";
    throw SceneError(field + ".points " + what + " (their hull has dimension " +
                     std::to_string(hull->dimension) + "); a convex shape needs a solid hull");
  }
  return ConvexShape{std::move(hull)};
}

// A mesh: within the budget and the coordinate range, validated by TriangleMesh, then
// represented as cheaply as the tolerance allows.
RepresentedMesh MakeMesh(const MeshSpec& spec, const std::string& field, const SceneSettings& settings) {
  const int pin = static_cast<int>(spec.pin);
  if (pin < 0 || pin >= static_cast<int>(Representation::kCount)) {
    throw SceneError(field + ".pin is " + std::to_string(pin) +
                     "; it must be one of auto, sphere, box, capsule, convex, mesh");
  }
  // the budget first: a mesh over it is refused before any work is spent on it
  if (spec.triangles.size() > settings.budgets.max_triangles_per_mesh) {
    throw SceneError(field + " has " + std::to_string(spec.triangles.size()) + " triangles; the budget is " +
                     std::to_string(settings.budgets.max_triangles_per_mesh) + " per mesh (max_triangles_per_mesh)");
  }
  // (non-finite ones are TriangleMesh's to name)
  for (size_t i = 0; i < spec.vertices.size(); ++i) {
    const Vector3& v = spec.vertices[i];
    if (v.allFinite() && v.cwiseAbs().maxCoeff() > L::kMaxCoordinate) {
      RequireWithin(v, L::kMaxCoordinate, field + ".vertices[" + std::to_string(i) + "]", "m");
    }
  }
  std::shared_ptr<const geometry::TriangleMesh> mesh;
  try {
    mesh = std::make_shared<const geometry::TriangleMesh>(spec.vertices, spec.triangles);
  } catch (const std::invalid_argument& e) {
    throw SceneError(field + ": " + e.what());
  }
  RepresentedMesh represented;
  try {
    represented = ChooseMeshRepresentation(mesh, settings.tolerance, spec.pin);
  } catch (const std::invalid_argument& e) {
    throw SceneError(field + ".pin: " + e.what());
  }
  // kept for reading the scene back, whatever represents it
  represented.choice.mesh = std::move(mesh);
  represented.choice.pin = spec.pin;
  return represented;
}

// The shape of spec (validated) and, for a mesh, how it is represented.
std::pair<Shape, RepresentationChoice> MakeShape(const ShapeSpec& spec, const std::string& field,
                                                 const SceneSettings& settings) {
  return std::visit(
      [&](const auto& s) -> std::pair<Shape, RepresentationChoice> {
        using S = std::decay_t<decltype(s)>;
        if constexpr (std::is_same_v<S, SphereShape>) {
          RequireSize(s.radius, field + ".radius");
          return {s, {}};
        } else if constexpr (std::is_same_v<S, BoxShape>) {
          for (int k = 0; k < 3; ++k) {
            RequireSize(s.half_extents[k], field + ".half_extents[" + std::to_string(k) + "]");
          }
          return {s, {}};
        } else if constexpr (std::is_same_v<S, CapsuleShape>) {
          RequireSize(s.radius, field + ".radius");
          RequireSize(s.half_length, field + ".half_length", true);
          return {s, {}};
        } else if constexpr (std::is_same_v<S, PlaneShape>) {
          return {s, {}};
        } else if constexpr (std::is_same_v<S, ConvexSpec>) {
          return {MakeConvex(s, field, settings.budgets), {}};
        } else {
          RepresentedMesh represented = MakeMesh(s, field, settings);
          return {std::move(represented.shape), std::move(represented.choice)};
        }
      },
      spec);
}

// Where the shape's frame S is and how it moves, from the client's frame B (a mesh's
// representation sits at X_BS in B; other shapes have S = B).
void Place(SceneObject& object, const Pose& X_WB, const Vector3& v_WB, const Vector3& w_WB) {
  object.X_WB = Compose(X_WB, object.representation.X_MS);
  object.w_WB = w_WB;
  object.v_WB = v_WB + w_WB.cross(X_WB.DirectionToWorld(object.representation.X_MS.translation));
  object.bounds_W = CalcWorldBounds(object.shape, object.X_WB);
}

// A validated, fully built object: everything that can fail happens here, before the
// builder changes.
SceneObject MakeObject(const ObjectSpec& spec, const SceneSettings& settings) {
  ValidateName(spec.name, settings.budgets);
  const std::string object = ObjectField(spec.name);
  ValidatePose(spec.X_WB, object);
  if (std::optional<std::string> problem = ValidateMaterial(spec.material, object + ".material")) {
    throw SceneError(*problem);
  }
  if (spec.motion != Motion::kStatic && spec.motion != Motion::kKinematic) {
    throw SceneError(object + ".motion is " + std::to_string(static_cast<int>(spec.motion)) +
                     "; it must be static or kinematic");
  }
  ValidateVelocities(spec.motion, spec.v_WB, spec.w_WB, object);
  // the shape last: a mesh's representation is the slow part
  SceneObject out;
  out.name = spec.name;
  std::tie(out.shape, out.representation) =
      MakeShape(spec.shape, object + ".shape", settings);
  out.material = spec.material;
  out.motion = spec.motion;
  Place(out, spec.X_WB, spec.v_WB, spec.w_WB);
  out.shape_digest = DigestShape(out.shape, out.representation);
  return out;
}

// Triangles an object keeps as a mesh (0 for every other representation).
std::size_t KeptTriangles(const SceneObject& object) {
  const auto* mesh = std::get_if<MeshShape>(&object.shape);
  return mesh != nullptr && mesh->bvh ? static_cast<std::size_t>(mesh->bvh->mesh().num_triangles()) : 0;
}

// The scene's triangle budget, where keeping `added` would bring the scene to total.
void RequireTriangleBudget(std::size_t total, const SceneObject& added, const SceneBudgets& budgets) {
  if (total > budgets.max_triangles) {
    throw SceneError(ObjectField(added.name) + " would bring the scene to " + std::to_string(total) +
                     " triangles; the budget is " + std::to_string(budgets.max_triangles) + " (max_triangles)");
  }
}

}  // namespace

SceneBuilder::SceneBuilder(SceneSettings settings) : settings_(settings) {
  RequirePositive(settings_.tolerance, "settings.tolerance");
}

const SceneObject& SceneBuilder::Add(const ObjectSpec& spec) {
  if (FindObject(spec.name) >= 0) throw SceneError(ObjectField(spec.name) + " already exists");
  if (static_cast<size_t>(objects_.size()) >= settings_.budgets.max_objects) {
    throw SceneError("the scene has " + std::to_string(objects_.size()) + " objects; the budget is " +
                     std::to_string(settings_.budgets.max_objects) + " (max_objects)");
  }
  SceneObject object = MakeObject(spec, settings_);
  const std::size_t kept_triangles = kept_triangles_ + KeptTriangles(object);
  RequireTriangleBudget(kept_triangles, object, settings_.budgets);
  AttachRayBackend(spec, object);
  objects_.PushBack(std::make_shared<SceneObject>(std::move(object)));
  kept_triangles_ = kept_triangles;
  const SceneObject& added = *objects_[num_objects() - 1];
  index_of_name_.emplace(added.name, num_objects() - 1);
  index_.Insert(num_objects() - 1, added.bounds_W, added.motion == Motion::kKinematic);
  if (added.motion == Motion::kKinematic) WritableKinematic().push_back(num_objects() - 1);
  return added;
}

const SceneObject& SceneBuilder::Update(const ObjectSpec& spec) {
  const int index = IndexOrThrow(spec.name);
  SceneObject object = MakeObject(spec, settings_);
  const std::size_t kept_triangles = kept_triangles_ - KeptTriangles(*objects_[index]) + KeptTriangles(object);
  RequireTriangleBudget(kept_triangles, object, settings_.budgets);
  AttachRayBackend(spec, object);
  const bool was_kinematic = objects_[index]->motion == Motion::kKinematic;
  // a new object: the snapshots that hold the old one keep it
  objects_.Writable(index) = std::make_shared<SceneObject>(std::move(object));
  kept_triangles_ = kept_triangles;
  const bool kinematic = objects_[index]->motion == Motion::kKinematic;
  index_.Move(index, objects_[index]->bounds_W, kinematic);
  if (kinematic != was_kinematic) {
    std::vector<int>& list = WritableKinematic();
    if (kinematic) {
      list.insert(std::lower_bound(list.begin(), list.end(), index), index);
    } else {
      std::erase(list, index);
    }
  }
  return *objects_[index];
}

void SceneBuilder::AttachRayBackend(const ObjectSpec& spec, SceneObject& object) {
  const RayBackend backend = spec.ray_backend.value_or(settings_.ray_backend);
  if (static_cast<int>(backend) < 0 || backend >= RayBackend::kCount) {
    throw SceneError(ObjectField(spec.name) + ".ray_backend is " + std::to_string(static_cast<int>(backend)) +
                     "; it must be native or embree");
  }
  auto* mesh = std::get_if<MeshShape>(&object.shape);
  if (mesh == nullptr || backend != RayBackend::kEmbree) return;
  // One Embree device for all of this builder's meshes, made when first needed.
  try {
    if (!embree_device_) embree_device_ = std::make_shared<const embree::EmbreeDevice>();
    mesh->embree = std::make_shared<const embree::EmbreeMesh>(embree_device_, mesh->bvh);
  } catch (const std::exception& e) {
    throw SceneError(ObjectField(spec.name) + ".ray_backend is embree, but Embree cannot hold this mesh: " +
                     e.what());
  }
}

void SceneBuilder::Remove(std::string_view name) {
  const int index = IndexOrThrow(name);
  index_of_name_.erase(objects_[index]->name);
  for (auto& [other, i] : index_of_name_) {
    if (i > index) --i;
  }
  kept_triangles_ -= KeptTriangles(*objects_[index]);
  objects_.Erase(index);
  index_.Erase(index);
  // the objects after it move down one index
  std::vector<int>& list = WritableKinematic();
  std::erase(list, index);
  for (int& k : list) {
    if (k > index) --k;
  }
}

void SceneBuilder::SetMaterial(std::string_view name, const Material& material) {
  const int index = IndexOrThrow(name);
  if (std::optional<std::string> problem =
          ValidateMaterial(material, ObjectField(name) + ".material")) {
    throw SceneError(*problem);
  }
  Writable(index).material = material;
}

void SceneBuilder::MoveKinematic(std::string_view name, const Pose& X_WB, const Vector3& v_WB,
                                 const Vector3& w_WB) {
  const int index = IndexOrThrow(name);
  const std::string object = ObjectField(name);
  if (objects_[index]->motion != Motion::kKinematic) {
    throw SceneError(object + " is static; only a kinematic object can be moved");
  }
  ValidatePose(X_WB, object);
  ValidateVelocities(Motion::kKinematic, v_WB, w_WB, object);
  SceneObject& target = Writable(index);
  const Vector3 before = target.X_WB.translation;
  Place(target, X_WB, v_WB, w_WB);
  index_.Move(index, target.bounds_W, true, target.X_WB.translation - before);
}

bool SceneBuilder::AdvanceKinematic(double dt) {
  if (!(dt >= 0) || !std::isfinite(dt)) return false;
  bool moved = false;
  for (const int index : *kinematic_) {
    const SceneObject& current = *objects_[index];
    if (current.v_WB.isZero(0) && current.w_WB.isZero(0)) continue;
    SceneObject& object = Writable(index);
    // back from the shape's frame S to the client's frame B, whose origin moves at v_WB
    const Pose& X_MS = object.representation.X_MS;
    Pose X_WB{object.X_WB.rotation * X_MS.rotation.transpose(), Vector3::Zero()};
    const Vector3 r_W = X_WB.rotation * X_MS.translation;
    X_WB.translation = object.X_WB.translation - r_W;
    const Vector3 v_WB = object.v_WB - object.w_WB.cross(r_W);
    // the rotation by w dt, exactly (Rodrigues), then the translation
    const double angle = object.w_WB.norm() * dt;
    if (angle > 0) {
      X_WB.rotation = Eigen::AngleAxisd(angle, object.w_WB.normalized()).toRotationMatrix() * X_WB.rotation;
    }
    X_WB.translation += v_WB * dt;
    const Vector3 before = object.X_WB.translation;
    Place(object, X_WB, v_WB, object.w_WB);
    index_.Move(index, object.bounds_W, true, object.X_WB.translation - before);
    moved = true;
  }
  return moved;
}

bool SceneBuilder::HasMovingObjects() const {
  return std::any_of(kinematic_->begin(), kinematic_->end(), [&](int index) {
    return !objects_[index]->v_WB.isZero(0) || !objects_[index]->w_WB.isZero(0);
  });
}

std::shared_ptr<const SceneSnapshot> SceneBuilder::Build(uint64_t version) const {
  // 0 marks an idle reader and ~0 a free one in the publisher's slots
  if (version == 0 || version == ~uint64_t{0}) {
    throw SceneError("version is " + std::to_string(version) +
                     "; snapshot versions run from 1 to 2^64 - 2");
  }
  return std::make_shared<const SceneSnapshot>(objects_, index_, kinematic_, settings_, version);
}

int SceneBuilder::FindObject(std::string_view name) const {
  const auto found = index_of_name_.find(name);
  return found == index_of_name_.end() ? -1 : found->second;
}

int SceneBuilder::IndexOrThrow(std::string_view name) const {
  const int index = FindObject(name);
  if (index < 0) throw SceneError(ObjectField(name) + " does not exist");
  return index;
}

std::vector<int>& SceneBuilder::WritableKinematic() {
  // shared with a snapshot: copy it first (as Writable below)
  if (kinematic_.use_count() > 1) kinematic_ = std::make_shared<std::vector<int>>(*kinematic_);
  return const_cast<std::vector<int>&>(*kinematic_);
}

SceneObject& SceneBuilder::Writable(int index) {
  // shared with a snapshot: copy it first (only this thread adds holders, so a count of
  // one cannot grow behind our back). Every object is made non-const (make_shared
  // <SceneObject>), so writing through the copy's pointer is sound.
  std::shared_ptr<const SceneObject>& entry = objects_.Writable(index);
  if (entry.use_count() > 1) entry = std::make_shared<SceneObject>(*entry);
  return const_cast<SceneObject&>(*entry);
}

}  // namespace hapticd::scene
