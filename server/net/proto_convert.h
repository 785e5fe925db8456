#pragma once
// Between the control channel's messages and the scene's and force code's own types.
// Reading validates what the message format cannot express (a shape must be set,
// flat arrays must hold whole points, quaternions must be unit) and throws RequestError
// naming the field by its path in the request ("add_object.object.shape.mesh.triangles
// has 7 values; it needs a multiple of 3"); the scene builder and the session settings
// check the rest.
#include <string>
#include "hapticd/v1/hapticd.pb.h"
#include "server/force/session_settings.h"
#include "server/remote/deadband.h"
#include "server/scene/scene_builder.h"

namespace hapticd::net {

// value itself when it is finite and > 0; else RequestError naming field and value.
double RequirePositive(double value, const std::string& field);
// value itself when it is in [low, high] (in (0, high] when low is 0); else
// RequestError naming field, value and the range.
double RequireInRange(double value, double low, double high, const std::string& field);
geometry::Vector3 ReadVector(const v1::Vec3& v, const std::string& field);
scene::Pose ReadPose(const v1::Pose& pose, bool present, const std::string& field);
scene::Material ReadMaterial(const v1::Material& material, const std::string& field);
// current with the fields change has replaced, checked as a whole (BadRequest naming
// `field`.stiffness etc.).
scene::Material ReadMaterialChange(const v1::MaterialChange& change, scene::Material current,
                                   const std::string& field);
scene::ObjectSpec ReadObject(const v1::Object& object, const std::string& field);

// The session settings an OpenSession asks for, validated; start_W receives the
// avatar's starting point and timeout_s the session's timeout.
force::SessionSettings ReadSessionRequest(const v1::OpenSession& open, geometry::Vector3& start_W,
                                          double& timeout_s);

// Whether an OpenSession asks for a local model (REMOTE_MODE_LOCAL_MODEL); RequestError
// for an unknown mode or a local model for an admittance device (its pose comes from
// the server's avatar dynamics).
bool ReadLocalModelMode(const v1::OpenSession& open);

// What an OpenSession asks of the channel: two-port passivity and the deadband, its
// zero fields read as the defaults (remote::DeadbandSettings), validated. RequestError
// naming the field for a value out of its bounds (remote::ValidateDeadband), or for tdpa
// or a deadband asked for an admittance device (impedance sessions only).
struct ChannelRequest {
  bool tdpa = false;
  remote::DeadbandSettings deadband;
};
ChannelRequest ReadChannelRequest(const v1::OpenSession& open);

void WriteVector(const geometry::Vector3& v, v1::Vec3* out);
void WritePose(const scene::Pose& pose, v1::Pose* out);
void WriteMaterial(const scene::Material& material, v1::Material* out);
// The object as GetScene describes it; a given mesh's vertices and triangles only
// with mesh_data (DescribeScene bounds how much that is).
void WriteObjectInfo(const scene::SceneObject& object, v1::ObjectInfo* out, bool mesh_data = false);

// The path of the first field in message (or below) that hapticd.v1 does not define,
// or "" when there is none: requests with unknown fields are refused, not half-read.
std::string FindUnknownField(const google::protobuf::Message& message, const std::string& path);

}  // namespace hapticd::net
