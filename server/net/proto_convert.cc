#include "server/net/proto_convert.h"

#include <cmath>
#include <type_traits>
#include <variant>

#include <fmt/format.h>
#include <google/protobuf/unknown_field_set.h>

#include "server/net/request_error.h"
#include "server/scene/shape.h"

namespace hapticd::net {
namespace {

using geometry::Vector3;

// Longest a session may stay silent before it is reclaimed, and the default.
constexpr double kMaxTimeoutS = 3600;
constexpr double kDefaultTimeoutS = 2;

std::vector<Vector3> ReadPoints(const google::protobuf::RepeatedField<double>& flat,
                                const std::string& field) {
  if (flat.size() % 3 != 0) {
    throw BadRequest(fmt::format("{} has {} values; it needs x, y, z for each point (a multiple of 3)",
                                 field, flat.size()));
  }
  std::vector<Vector3> points(flat.size() / 3);
  for (std::size_t i = 0; i < points.size(); ++i) {
    points[i] = {flat[3 * i], flat[3 * i + 1], flat[3 * i + 2]};
  }
  return points;
}

scene::Representation ReadRepresentation(v1::Representation representation) {
  switch (representation) {
    case v1::REPRESENTATION_SPHERE: return scene::Representation::kSphere;
    case v1::REPRESENTATION_BOX: return scene::Representation::kBox;
    case v1::REPRESENTATION_CAPSULE: return scene::Representation::kCapsule;
    case v1::REPRESENTATION_CONVEX: return scene::Representation::kConvex;
    case v1::REPRESENTATION_MESH: return scene::Representation::kMesh;
    default: return scene::Representation::kAuto;
  }
}

scene::MeshSpec ReadMesh(const v1::Mesh& mesh, const std::string& field) {
  scene::MeshSpec spec;
  spec.vertices = ReadPoints(mesh.vertices(), field + ".vertices");
  const auto& indices = mesh.triangles();
  if (indices.size() % 3 != 0) {
    throw BadRequest(fmt::format("{}.triangles has {} values; it needs 3 vertex indices per triangle",
                                 field, indices.size()));
  }
  spec.triangles.resize(indices.size() / 3);
  for (int i = 0; i < indices.size(); ++i) {
    if (indices[i] >= spec.vertices.size()) {
      throw BadRequest(fmt::format("{}.triangles[{}] is {}; the mesh has {} vertices", field, i,
                                   indices[i], spec.vertices.size()));
    }
    spec.triangles[i / 3][i % 3] = static_cast<int>(indices[i]);
  }
  spec.pin = ReadRepresentation(mesh.representation());
  return spec;
}

scene::ShapeSpec ReadShape(const v1::Shape& shape, const std::string& field) {
  switch (shape.kind_case()) {
    case v1::Shape::kSphere:
      return scene::SphereShape{shape.sphere().radius()};
    case v1::Shape::kBox:
      return scene::BoxShape{ReadVector(shape.box().half_extents(), field + ".box.half_extents")};
    case v1::Shape::kCapsule:
      return scene::CapsuleShape{shape.capsule().radius(), shape.capsule().half_length()};
    case v1::Shape::kPlane:
      return scene::PlaneShape{};
    case v1::Shape::kConvex:
      return scene::ConvexSpec{ReadPoints(shape.convex().points(), field + ".convex.points")};
    case v1::Shape::kMesh:
      return ReadMesh(shape.mesh(), field + ".mesh");
    case v1::Shape::KIND_NOT_SET:
      break;
  }
  throw BadRequest(field + " is not set; it must be one of sphere, box, capsule, plane, convex, mesh");
}

}  // namespace

double RequirePositive(double value, const std::string& field) {
  if (!(std::isfinite(value) && value > 0)) {
    throw BadRequest(fmt::format("{} is {}; it must be a finite number > 0", field, value));
  }
  return value;
}

double RequireInRange(double value, double low, double high, const std::string& field) {
  // low 0 means "> 0": a limit of zero renders nothing
  const bool above = low == 0 ? value > 0 : value >= low;
  if (!(above && value <= high)) {
    throw BadRequest(fmt::format("{} is {}; it must be in {}{}, {}]", field, value, low == 0 ? "(" : "[",
                                 low, high));
  }
  return value;
}

Vector3 ReadVector(const v1::Vec3& v, const std::string& field) {
  const Vector3 result(v.x(), v.y(), v.z());
  if (!result.allFinite()) {
    throw BadRequest(fmt::format("{} is [{}, {}, {}]; it must be finite", field, v.x(), v.y(), v.z()));
  }
  return result;
}

scene::Pose ReadPose(const v1::Pose& pose, bool present, const std::string& field) {
  scene::Pose result;
  if (!present) return result;
  result.translation = ReadVector(pose.position(), field + ".position");
  if (pose.has_orientation()) {
    const v1::Quat& q = pose.orientation();
    const double norm = std::sqrt(q.w() * q.w() + q.x() * q.x() + q.y() * q.y() + q.z() * q.z());
    if (!(std::abs(norm - 1) <= 1e-6)) {
      throw BadRequest(fmt::format("{}.orientation is [{}, {}, {}, {}] (w, x, y, z) with norm {}; "
                                   "it must be a unit quaternion",
                                   field, q.w(), q.x(), q.y(), q.z(), norm));
    }
    result.rotation = Eigen::Quaterniond(q.w(), q.x(), q.y(), q.z()).normalized().toRotationMatrix();
  }
  return result;
}

scene::Material ReadMaterial(const v1::Material& material, const std::string& field) {
  scene::Material result;
  result.stiffness = material.stiffness();
  result.damping = material.damping();
  result.static_friction = material.static_friction();
  result.dynamic_friction = material.dynamic_friction();
  result.force_shading = material.has_force_shading() ? material.force_shading() : true;
  if (auto error = scene::ValidateMaterial(result, field)) throw BadRequest(*error);
  return result;
}

scene::Material ReadMaterialChange(const v1::MaterialChange& change, scene::Material current,
                                   const std::string& field) {
  if (change.has_stiffness()) current.stiffness = change.stiffness();
  if (change.has_damping()) current.damping = change.damping();
  if (change.has_static_friction()) current.static_friction = change.static_friction();
  if (change.has_dynamic_friction()) current.dynamic_friction = change.dynamic_friction();
  if (change.has_force_shading()) current.force_shading = change.force_shading();
  if (auto error = scene::ValidateMaterial(current, field)) throw BadRequest(*error);
  return current;
}

scene::ObjectSpec ReadObject(const v1::Object& object, const std::string& field) {
  scene::ObjectSpec spec;
  if (object.name().empty()) throw BadRequest(field + ".name is empty; every object needs a name");
  spec.name = object.name();
  if (!object.has_shape()) throw BadRequest(field + ".shape is missing");
  spec.shape = ReadShape(object.shape(), field + ".shape");
  spec.X_WB = ReadPose(object.pose(), object.has_pose(), field + ".pose");
  if (!object.has_material()) {
    throw BadRequest(field + ".material is missing; an object needs at least a stiffness");
  }
  spec.material = ReadMaterial(object.material(), field + ".material");
  spec.motion = object.kinematic() ? scene::Motion::kKinematic : scene::Motion::kStatic;
  spec.v_WB = ReadVector(object.velocity(), field + ".velocity");
  spec.w_WB = ReadVector(object.angular_velocity(), field + ".angular_velocity");
  switch (object.ray_backend()) {
    case v1::RAY_BACKEND_DEFAULT: break;
    case v1::RAY_BACKEND_NATIVE: spec.ray_backend = scene::RayBackend::kNative; break;
    case v1::RAY_BACKEND_EMBREE: spec.ray_backend = scene::RayBackend::kEmbree; break;
    default:
      throw BadRequest(fmt::format("{}.ray_backend is {}; it must be default, native or embree", field,
                                   static_cast<int>(object.ray_backend())));
  }
  if (!object.kinematic() && (!spec.v_WB.isZero(0) || !spec.w_WB.isZero(0))) {
    throw BadRequest(field + " is static but has a velocity; set kinematic to move it");
  }
  return spec;
}

force::SessionSettings ReadSessionRequest(const v1::OpenSession& open, Vector3& start_W,
                                          double& timeout_s) {
  const std::string field = "open_session";
  force::SessionSettings settings;
  switch (open.device_type()) {
    case v1::DEVICE_TYPE_IMPEDANCE: settings.device.mode = force::DeviceMode::kImpedance; break;
    case v1::DEVICE_TYPE_ADMITTANCE: settings.device.mode = force::DeviceMode::kAdmittance; break;
    default:
      throw BadRequest(fmt::format("{}.device_type is {}; it must be impedance or admittance", field,
                                   v1::DeviceType_Name(open.device_type())));
  }
  if (open.degrees_of_freedom() != 3 && open.degrees_of_freedom() != 6) {
    throw BadRequest(fmt::format("{}.degrees_of_freedom is {}; hapticd renders 3 or 6", field,
                                 open.degrees_of_freedom()));
  }
  using L = force::SessionLimits;
  settings.device.max_force = RequireInRange(open.max_force(), 0, L::kMaxForce, field + ".max_force");
  settings.device.max_velocity = RequireInRange(open.max_velocity(), 0, L::kMaxVelocity, field + ".max_velocity");
  settings.device.rate_hz = RequireInRange(open.rate_hz(), L::kMinRateHz, L::kMaxRateHz, field + ".rate_hz");
  settings.device.max_force_rate = open.max_force_rate() == 0
                                       ? std::numeric_limits<double>::infinity()
                                       : RequirePositive(open.max_force_rate(), field + ".max_force_rate");

  // The avatar, and the method its type calls for unless one is named.
  const bool sphere = open.avatar() == v1::AVATAR_TYPE_SPHERE;
  settings.avatar.type = sphere ? force::AvatarType::kSphere : force::AvatarType::kPoint;
  settings.avatar.radius = open.avatar_radius();
  settings.avatar.force_shading = open.force_shading();
  switch (open.method()) {
    case v1::FORCE_METHOD_PENALTY: settings.avatar.method = force::ForceMethod::kPenalty; break;
    case v1::FORCE_METHOD_GOD_OBJECT: settings.avatar.method = force::ForceMethod::kGodObject; break;
    case v1::FORCE_METHOD_FINGER_PROXY: settings.avatar.method = force::ForceMethod::kFingerProxy; break;
    default:
      settings.avatar.method = sphere ? force::ForceMethod::kFingerProxy : force::ForceMethod::kGodObject;
  }
  if (open.virtual_mass() != 0) settings.admittance.virtual_mass = open.virtual_mass();
  if (open.virtual_damping() != 0) settings.admittance.virtual_damping = open.virtual_damping();
  settings.control.passivity = open.passivity();
  if (auto error = force::ValidateSessionSettings(settings)) throw BadRequest(field + "." + *error);

  start_W = ReadVector(open.start(), field + ".start");
  timeout_s = open.timeout_s() == 0 ? kDefaultTimeoutS : open.timeout_s();
  const double min_timeout_s = settings.control.watchdog_timeout_s + settings.control.watchdog_ramp_s;
  if (!(timeout_s >= min_timeout_s && timeout_s <= kMaxTimeoutS)) {
    throw BadRequest(fmt::format("{}.timeout_s is {}; it must be in [{}, {}] (the watchdog's ramp must "
                                 "end first)",
                                 field, open.timeout_s(), min_timeout_s, kMaxTimeoutS));
  }
  return settings;
}

bool ReadLocalModelMode(const v1::OpenSession& open) {
  switch (open.remote_mode()) {
    case v1::REMOTE_MODE_DIRECT: return false;
    case v1::REMOTE_MODE_LOCAL_MODEL:
      if (open.device_type() == v1::DEVICE_TYPE_ADMITTANCE) {
        throw BadRequest("open_session.remote_mode is local_model for an admittance device; a local model is "
                         "for impedance devices (an admittance device's pose comes from the server's avatar)");
      }
      return true;
    default:
      throw BadRequest(fmt::format("open_session.remote_mode is {}; it must be direct (0) or local_model (1)",
                                   static_cast<int>(open.remote_mode())));
  }
}

ChannelRequest ReadChannelRequest(const v1::OpenSession& open) {
  ChannelRequest request;
  request.tdpa = open.tdpa();
  remote::DeadbandSettings& deadband = request.deadband;
  deadband.weber = open.deadband();
  // a zero floor or keep-alive asks for the default
  const auto read = [](double value, double fallback) { return value == 0 ? fallback : value; };
  deadband.force_floor_n = read(open.deadband_force_floor(), remote::kForceFloorN);
  deadband.position_floor_m = read(open.deadband_position_floor(), remote::kPositionFloorM);
  deadband.velocity_floor_mps = read(open.deadband_velocity_floor(), remote::kVelocityFloorMps);
  deadband.keepalive_s = read(open.keepalive_s(), remote::DeadbandSettings{}.keepalive_s);
  if (auto error = remote::ValidateDeadband(deadband)) throw BadRequest("open_session." + *error);
  if (open.device_type() == v1::DEVICE_TYPE_ADMITTANCE) {
    if (request.tdpa) {
      throw BadRequest("open_session.tdpa is true for an admittance device; two-port passivity is for impedance "
                       "devices (position up, force down)");
    }
    if (deadband.on()) {
      throw BadRequest(fmt::format("open_session.deadband is {} for an admittance device; the deadband is for "
                                   "impedance devices",
                                   deadband.weber));
    }
  }
  return request;
}

void WriteVector(const Vector3& v, v1::Vec3* out) {
  out->set_x(v.x());
  out->set_y(v.y());
  out->set_z(v.z());
}

void WritePose(const scene::Pose& pose, v1::Pose* out) {
  WriteVector(pose.translation, out->mutable_position());
  const Eigen::Quaterniond q(pose.rotation);
  v1::Quat* orientation = out->mutable_orientation();
  orientation->set_w(q.w());
  orientation->set_x(q.x());
  orientation->set_y(q.y());
  orientation->set_z(q.z());
}

void WriteMaterial(const scene::Material& material, v1::Material* out) {
  out->set_stiffness(material.stiffness);
  out->set_damping(material.damping);
  out->set_static_friction(material.static_friction);
  out->set_dynamic_friction(material.dynamic_friction);
  out->set_force_shading(material.force_shading);
}

namespace {

v1::Representation WriteRepresentation(scene::Representation representation) {
  switch (representation) {
    case scene::Representation::kSphere: return v1::REPRESENTATION_SPHERE;
    case scene::Representation::kBox: return v1::REPRESENTATION_BOX;
    case scene::Representation::kCapsule: return v1::REPRESENTATION_CAPSULE;
    case scene::Representation::kConvex: return v1::REPRESENTATION_CONVEX;
    case scene::Representation::kMesh: return v1::REPRESENTATION_MESH;
    default: return v1::REPRESENTATION_AUTO;
  }
}

// The stored shape's parameters, in its own frame (a mesh's data goes with the given
// mesh instead: the frames coincide).
void WriteRepresentedShape(const scene::Shape& shape, v1::Shape* out) {
  std::visit(
      [out](const auto& s) {
        using S = std::decay_t<decltype(s)>;
        if constexpr (std::is_same_v<S, scene::SphereShape>) {
          out->mutable_sphere()->set_radius(s.radius);
        } else if constexpr (std::is_same_v<S, scene::BoxShape>) {
          WriteVector(s.half_extents, out->mutable_box()->mutable_half_extents());
        } else if constexpr (std::is_same_v<S, scene::CapsuleShape>) {
          out->mutable_capsule()->set_radius(s.radius);
          out->mutable_capsule()->set_half_length(s.half_length);
        } else if constexpr (std::is_same_v<S, scene::PlaneShape>) {
          out->mutable_plane();
        } else if constexpr (std::is_same_v<S, scene::ConvexShape>) {
          auto* points = out->mutable_convex()->mutable_points();
          points->Reserve(static_cast<int>(3 * s.hull->vertices.size()));
          for (const Vector3& p : s.hull->vertices) points->Add(p.data(), p.data() + 3);
        } else {
          out->mutable_mesh()->set_representation(v1::REPRESENTATION_MESH);
        }
      },
      shape);
}

// The mesh an object was given as, in its frame M, and M's pose: X_WM = X_WS X_MS^-1.
void WriteGivenMesh(const scene::SceneObject& object, bool mesh_data, v1::ObjectInfo* out) {
  const scene::RepresentationChoice& choice = object.representation;
  v1::Mesh* mesh = out->mutable_mesh();
  mesh->set_representation(WriteRepresentation(choice.pin));
  if (mesh_data) {
    const geometry::TriangleMesh& given = *choice.mesh;
    auto* vertices = mesh->mutable_vertices();
    vertices->Reserve(3 * given.num_vertices());
    for (const Vector3& v : given.vertices()) vertices->Add(v.data(), v.data() + 3);
    auto* triangles = mesh->mutable_triangles();
    triangles->Reserve(3 * given.num_triangles());
    for (const auto& t : given.triangles()) {
      for (const int k : t) triangles->Add(static_cast<uint32_t>(k));
    }
  }
  scene::Pose X_WM;
  X_WM.rotation = object.X_WB.rotation * choice.X_MS.rotation.transpose();
  X_WM.translation = object.X_WB.translation - X_WM.rotation * choice.X_MS.translation;
  WritePose(X_WM, out->mutable_mesh_pose());
}

}  // namespace

void WriteObjectInfo(const scene::SceneObject& object, v1::ObjectInfo* out, bool mesh_data) {
  const scene::ShapeType stored = scene::TypeOf(object.shape);
  const bool was_mesh = object.representation.chosen != scene::Representation::kAuto;
  out->set_name(object.name);
  out->set_shape(std::string(scene::ShapeTypeName(was_mesh ? scene::ShapeType::kMesh : stored)));
  out->set_representation(std::string(scene::ShapeTypeName(stored)));
  out->set_representation_error(object.representation.error_bound);
  WriteVector(object.bounds_W.min, out->mutable_bounds_min());
  WriteVector(object.bounds_W.max, out->mutable_bounds_max());
  WritePose(object.X_WB, out->mutable_pose());
  WriteMaterial(object.material, out->mutable_material());
  out->set_kinematic(object.motion == scene::Motion::kKinematic);
  // a mesh's closure and warnings, whatever represents it
  if (was_mesh) {
    out->set_closed(object.representation.closure == geometry::MeshClosure::kClosed);
    out->set_topology(std::string(geometry::MeshClosureName(object.representation.closure)));
    out->set_rewound_triangles(static_cast<uint32_t>(object.representation.rewound_triangles));
    for (const std::string& warning : object.representation.warnings) out->add_warnings(warning);
  }
  if (const auto* mesh = std::get_if<scene::MeshShape>(&object.shape)) {
    const geometry::TriangleMesh& triangles = mesh->bvh->mesh();
    out->set_triangles(static_cast<uint32_t>(triangles.num_triangles()));
    out->set_dropped_triangles(static_cast<uint32_t>(triangles.num_degenerate_triangles()));
    out->set_repeated_triangles(static_cast<uint32_t>(triangles.num_repeated_triangles()));
    out->set_ray_backend(std::string(
        scene::RayBackendName(mesh->embree ? scene::RayBackend::kEmbree : scene::RayBackend::kNative)));
  }
  // read back: the shape, the given mesh, the velocities of the client's frame
  WriteRepresentedShape(object.shape, out->mutable_represented_shape());
  if (object.representation.mesh) WriteGivenMesh(object, mesh_data, out);
  if (object.motion == scene::Motion::kKinematic) {
    // the stored velocity is of S's origin; the client's frame M sits r_W behind it
    const Vector3 r_W = object.X_WB.rotation * object.representation.X_MS.rotation.transpose() *
                        object.representation.X_MS.translation;
    WriteVector(object.v_WB - object.w_WB.cross(r_W), out->mutable_velocity());
    WriteVector(object.w_WB, out->mutable_angular_velocity());
  }
  out->set_shape_digest(object.shape_digest);
}

std::string FindUnknownField(const google::protobuf::Message& message, const std::string& path) {
  const google::protobuf::Reflection* reflection = message.GetReflection();
  const google::protobuf::UnknownFieldSet& unknown = reflection->GetUnknownFields(message);
  if (!unknown.empty()) return fmt::format("{} field number {}", path, unknown.field(0).number());
  std::vector<const google::protobuf::FieldDescriptor*> fields;
  reflection->ListFields(message, &fields);
  for (const auto* field : fields) {
    if (field->cpp_type() != google::protobuf::FieldDescriptor::CPPTYPE_MESSAGE) continue;
    const std::string child_path = path + "." + field->name();
    if (field->is_repeated()) {
      for (int i = 0; i < reflection->FieldSize(message, field); ++i) {
        auto found = FindUnknownField(reflection->GetRepeatedMessage(message, field, i),
                                      fmt::format("{}[{}]", child_path, i));
        if (!found.empty()) return found;
      }
    } else {
      auto found = FindUnknownField(reflection->GetMessage(message, field), child_path);
      if (!found.empty()) return found;
    }
  }
  return "";
}

}  // namespace hapticd::net
