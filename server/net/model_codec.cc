#include "server/net/model_codec.h"

#include <algorithm>

#include <fmt/format.h>

#include "hapticd/v1/hapticd.pb.h"
#include "server/net/proto_convert.h"
#include "server/net/request_error.h"

namespace hapticd::net {
namespace {

void WriteShape(const scene::ShapeSpec& shape, v1::Shape* out) {
  std::visit(
      [out](const auto& s) {
        using T = std::decay_t<decltype(s)>;
        if constexpr (std::is_same_v<T, scene::SphereShape>) {
          out->mutable_sphere()->set_radius(s.radius);
        } else if constexpr (std::is_same_v<T, scene::BoxShape>) {
          WriteVector(s.half_extents, out->mutable_box()->mutable_half_extents());
        } else if constexpr (std::is_same_v<T, scene::CapsuleShape>) {
          out->mutable_capsule()->set_radius(s.radius);
          out->mutable_capsule()->set_half_length(s.half_length);
        } else if constexpr (std::is_same_v<T, scene::PlaneShape>) {
          out->mutable_plane();
        } else if constexpr (std::is_same_v<T, scene::ConvexSpec>) {
          auto* points = out->mutable_convex()->mutable_points();
          for (const Vector3& p : s.points) points->Add(p.data(), p.data() + 3);
        } else {
          v1::Mesh* mesh = out->mutable_mesh();
          for (const Vector3& v : s.vertices) mesh->mutable_vertices()->Add(v.data(), v.data() + 3);
          for (const auto& t : s.triangles) {
            for (int k : t) mesh->add_triangles(static_cast<uint32_t>(k));
          }
          // a patch is a mesh as it is: never re-represented on the device
          mesh->set_representation(s.pin == scene::Representation::kMesh ? v1::REPRESENTATION_MESH
                                                                          : v1::REPRESENTATION_AUTO);
        }
      },
      shape);
}

void WriteObject(const scene::ObjectSpec& spec, v1::Object* out) {
  out->set_name(spec.name);
  WriteShape(spec.shape, out->mutable_shape());
  WritePose(spec.X_WB, out->mutable_pose());
  WriteMaterial(spec.material, out->mutable_material());
  if (spec.motion == scene::Motion::kKinematic) {
    out->set_kinematic(true);
    WriteVector(spec.v_WB, out->mutable_velocity());
    WriteVector(spec.w_WB, out->mutable_angular_velocity());
  }
}

}  // namespace

std::string EncodeLocalModel(const remote::LocalModel& model) {
  v1::LocalModel message;
  message.set_version(model.version);
  message.set_time_s(model.t_s);
  WriteVector(model.center_W, message.mutable_center());
  message.set_radius(model.radius);
  message.set_tolerance(model.settings.tolerance);
  int left_out = model.left_out;
  for (const scene::ObjectSpec& spec : model.objects) WriteObject(spec, message.add_objects());
  message.set_left_out(static_cast<uint32_t>(left_out));
  while (message.ByteSizeLong() > kMaxModelBytes && message.objects_size() > 0) {
    message.mutable_objects()->RemoveLast();
    message.set_left_out(static_cast<uint32_t>(++left_out));
  }
  return message.SerializeAsString();
}

remote::LocalModel DecodeLocalModel(std::span<const uint8_t> bytes) {
  v1::LocalModel message;
  if (!message.ParseFromArray(bytes.data(), static_cast<int>(bytes.size()))) {
    throw BadRequest(fmt::format("local_model: {} bytes that do not parse as a hapticd.v1.LocalModel", bytes.size()));
  }
  remote::LocalModel model;
  model.version = message.version();
  if (model.version == 0) throw BadRequest("local_model.version is 0; models count from 1");
  model.t_s = message.time_s();
  model.center_W = ReadVector(message.center(), "local_model.center");
  model.radius = RequireInRange(message.radius(), 0, remote::kMaxModelRadiusM, "local_model.radius");
  model.settings.tolerance = RequirePositive(message.tolerance(), "local_model.tolerance");
  model.settings.ray_backend = scene::RayBackend::kNative;
  if (message.objects_size() > remote::kMaxModelObjects) {
    throw BadRequest(fmt::format("local_model.objects has {} objects; a model holds at most {}",
                                 message.objects_size(), remote::kMaxModelObjects));
  }
  for (int i = 0; i < message.objects_size(); ++i) {
    model.objects.push_back(ReadObject(message.objects(i), fmt::format("local_model.objects[{}]", i)));
    model.objects.back().ray_backend = scene::RayBackend::kNative;
  }
  model.left_out = static_cast<int>(message.left_out());
  return model;
}

uint32_t FragmentCount(std::size_t bytes) {
  return static_cast<uint32_t>(std::max<std::size_t>(1, (bytes + kModelChunkSize - 1) / kModelChunkSize));
}

ModelFragmentView Fragment(std::span<const uint8_t> encoded, uint64_t version, uint32_t index) {
  ModelFragmentView fragment;
  fragment.version = version;
  fragment.index = index;
  fragment.count = FragmentCount(encoded.size());
  const std::size_t begin = std::min<std::size_t>(std::size_t{index} * kModelChunkSize, encoded.size());
  fragment.data = encoded.subspan(begin, std::min(kModelChunkSize, encoded.size() - begin));
  return fragment;
}

ModelAssembler::ModelAssembler() : buffer_(kMaxModelBytes) {}

bool ModelAssembler::Offer(const ModelFragmentView& fragment) {
  if (fragment.version < version_ || (fragment.version == version_ && complete_)) return false;
  const bool last = fragment.index + 1 == fragment.count;
  if (fragment.count == 0 || fragment.index >= fragment.count || fragment.count > kMaxModelFragments ||
      (last ? fragment.data.size() > kModelChunkSize : fragment.data.size() != kModelChunkSize) ||
      (fragment.version == version_ && fragment.count != count_)) {
    ++rejected_;
    return false;
  }
  if (fragment.version > version_) {
    version_ = fragment.version;
    count_ = fragment.count;
    have_.reset();
    size_ = 0;
    complete_ = false;
  }
  std::copy(fragment.data.begin(), fragment.data.end(), buffer_.begin() + std::size_t{fragment.index} * kModelChunkSize);
  if (last) size_ = std::size_t{fragment.index} * kModelChunkSize + fragment.data.size();
  have_.set(fragment.index);
  complete_ = have_.count() == count_;
  return complete_;
}

}  // namespace hapticd::net
