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
#include "server/scene/value_text.h"

namespace hapticd::scene {
namespace {

// How far R^T R may be from the identity (Frobenius norm).
constexpr double kRotationTolerance = 1e-6;

std::string ObjectField(std::string_view name) { return "objects[" + std::string(name) + "]"; }

// "<field> is <value>; it must be a finite number > 0" unless value is one.
void RequirePositive(double value, const std::string& field) {
  if (!(value > 0) || !std::isfinite(value)) {
    throw SceneError(field + " is " + FormatExact(value) + "; it must be a finite number > 0");
  }
}

void RequireNonNegative(double value, const std::string& field) {
  if (!(value >= 0) || !std::isfinite(value)) {
    throw SceneError(field + " is " + FormatExact(value) + "; it must be a finite number >= 0");
  }
}

void RequireFinite(const Vector3& v, const std::string& field) {
  if (!v.allFinite()) throw SceneError(field + " is " + FormatExact(v) + "; it must be finite");
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
  RequireFinite(X.translation, object + ".translation");
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

// A convex shape: finite points of bounded size whose hull is a solid.
ConvexShape MakeConvex(const ConvexSpec& spec, const std::string& field) {
  if (spec.points.empty()) {
    throw SceneError(field + ".points is empty; a convex shape needs at least 4 points");
  }
  for (size_t i = 0; i < spec.points.size(); ++i) {
    const Vector3& p = spec.points[i];
    const std::string point = field + ".points[" + std::to_string(i) + "]";
    RequireFinite(p, point);
    if (p.cwiseAbs().maxCoeff() > geometry::kMaxHullCoordinate) {
      throw SceneError(point + " is " + FormatExact(p) +
                       "; its coordinates must be at most 1e100 in magnitude");
    }
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

// A mesh: validated by TriangleMesh, then represented as cheaply as the tolerance allows.
RepresentedMesh MakeMesh(const MeshSpec& spec, const std::string& field, double tolerance) {
  const int pin = static_cast<int>(spec.pin);
  if (pin < 0 || pin >= static_cast<int>(Representation::kCount)) {
    throw SceneError(field + ".pin is " + std::to_string(pin) +
                     "; it must be one of auto, sphere, box, capsule, convex, mesh");
  }
  std::shared_ptr<const geometry::TriangleMesh> mesh;
  try {
    mesh = std::make_shared<const geometry::TriangleMesh>(spec.vertices, spec.triangles);
  } catch (const std::invalid_argument& e) {
    throw SceneError(field + ": " + e.what());
  }
  try {
    return ChooseMeshRepresentation(std::move(mesh), tolerance, spec.pin);
  } catch (const std::invalid_argument& e) {
    throw SceneError(field + ".pin: " + e.what());
  }
}

// The shape of spec (validated) and, for a mesh, how it is represented.
std::pair<Shape, RepresentationChoice> MakeShape(const ShapeSpec& spec, const std::string& field,
                                                 double tolerance) {
  return std::visit(
      [&](const auto& s) -> std::pair<Shape, RepresentationChoice> {
        using S = std::decay_t<decltype(s)>;
        if constexpr (std::is_same_v<S, SphereShape>) {
          RequirePositive(s.radius, field + ".radius");
          return {s, {}};
        } else if constexpr (std::is_same_v<S, BoxShape>) {
          for (int k = 0; k < 3; ++k) {
            RequirePositive(s.half_extents[k], field + ".half_extents[" + std::to_string(k) + "]");
          }
          return {s, {}};
        } else if constexpr (std::is_same_v<S, CapsuleShape>) {
          RequirePositive(s.radius, field + ".radius");
          RequireNonNegative(s.half_length, field + ".half_length");
          return {s, {}};
        } else if constexpr (std::is_same_v<S, PlaneShape>) {
          return {s, {}};
        } else if constexpr (std::is_same_v<S, ConvexSpec>) {
          return {MakeConvex(s, field), {}};
        } else {
          RepresentedMesh represented = MakeMesh(s, field, tolerance);
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
  if (spec.name.empty()) throw SceneError("objects[] name is empty");
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
      MakeShape(spec.shape, object + ".shape", settings.tolerance);
  out.material = spec.material;
  out.motion = spec.motion;
  Place(out, spec.X_WB, spec.v_WB, spec.w_WB);
  return out;
}

}  // namespace

SceneBuilder::SceneBuilder(SceneSettings settings) : settings_(settings) {
  RequirePositive(settings_.tolerance, "settings.tolerance");
}

SceneBuilder::SceneBuilder(const SceneSnapshot& base)
    : settings_(base.settings()), objects_(base.objects().begin(), base.objects().end()) {}

const SceneObject& SceneBuilder::Add(const ObjectSpec& spec) {
  if (std::any_of(objects_.begin(), objects_.end(),
                  [&](const SceneObject& o) { return o.name == spec.name; })) {
    throw SceneError(ObjectField(spec.name) + " already exists");
  }
  SceneObject object = MakeObject(spec, settings_);
  AttachRayBackend(spec, object);
  objects_.push_back(std::move(object));
  return objects_.back();
}

const SceneObject& SceneBuilder::Update(const ObjectSpec& spec) {
  SceneObject& target = FindOrThrow(spec.name);
  SceneObject object = MakeObject(spec, settings_);
  AttachRayBackend(spec, object);
  target = std::move(object);
  return target;
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
  SceneObject& target = FindOrThrow(name);
  objects_.erase(objects_.begin() + (&target - objects_.data()));
}

void SceneBuilder::SetMaterial(std::string_view name, const Material& material) {
  SceneObject& target = FindOrThrow(name);
  if (std::optional<std::string> problem =
          ValidateMaterial(material, ObjectField(name) + ".material")) {
    throw SceneError(*problem);
  }
  target.material = material;
}

void SceneBuilder::MoveKinematic(std::string_view name, const Pose& X_WB, const Vector3& v_WB,
                                 const Vector3& w_WB) {
  SceneObject& target = FindOrThrow(name);
  const std::string object = ObjectField(name);
  if (target.motion != Motion::kKinematic) {
    throw SceneError(object + " is static; only a kinematic object can be moved");
  }
  ValidatePose(X_WB, object);
  ValidateVelocities(target.motion, v_WB, w_WB, object);
  Place(target, X_WB, v_WB, w_WB);
}

std::shared_ptr<const SceneSnapshot> SceneBuilder::Build(uint64_t version) const {
  // 0 marks an idle reader and ~0 a free one in the publisher's slots
  if (version == 0 || version == ~uint64_t{0}) {
    throw SceneError("version is " + std::to_string(version) +
                     "; snapshot versions run from 1 to 2^64 - 2");
  }
  return std::make_shared<const SceneSnapshot>(objects_, settings_, version);
}

SceneObject& SceneBuilder::FindOrThrow(std::string_view name) {
  for (SceneObject& object : objects_) {
    if (object.name == name) return object;
  }
  throw SceneError(ObjectField(name) + " does not exist");
}

}  // namespace hapticd::scene
