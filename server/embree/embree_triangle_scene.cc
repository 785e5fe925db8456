#include "server/embree/embree_triangle_scene.h"

#include <stdexcept>

namespace hapticd::embree {

using geometry::Vector3;

EmbreeTriangleScene::EmbreeTriangleScene(std::shared_ptr<const EmbreeDevice> device,
                                         std::shared_ptr<const geometry::TriangleMesh> mesh,
                                         const TriangleSceneOptions& options)
    : device_(std::move(device)), mesh_(std::move(mesh)), robust_(options.robust) {
  if (device_ == nullptr) throw std::invalid_argument("EmbreeTriangleScene: the device is null");
  if (mesh_ == nullptr) throw std::invalid_argument("EmbreeTriangleScene: the mesh is null");
  RTCDevice handle = device_->handle();
  // errors left from earlier calls are not this build's
  device_->TakeError();
  scene_ = rtcNewScene(handle);
  try {
    rtcSetSceneBuildQuality(scene_, options.quality);
    rtcSetSceneFlags(scene_, options.robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
    RTCGeometry geometry = rtcNewGeometry(handle, RTC_GEOMETRY_TYPE_TRIANGLE);

    // vertices, rounded to the nearest float (Embree pads the buffer for its SIMD loads)
    const std::vector<Vector3>& vertices = mesh_->vertices();
    auto* xyz = static_cast<float*>(rtcSetNewGeometryBuffer(
        geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), vertices.size()));
    // indices of the non-degenerate triangles; Embree's primID indexes this list
    const std::vector<int>& kept = mesh_->nondegenerate_triangles();
    auto* index = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), kept.size()));
    if (xyz == nullptr || index == nullptr) {
      rtcReleaseGeometry(geometry);
      device_->ThrowIfError("rtcSetNewGeometryBuffer (EmbreeTriangleScene)");
      throw std::runtime_error("Embree returned no geometry buffer (EmbreeTriangleScene)");
    }
    for (size_t i = 0; i < vertices.size(); ++i) {
      for (int a = 0; a < 3; ++a) xyz[3 * i + a] = static_cast<float>(vertices[i][a]);
    }
    for (size_t i = 0; i < kept.size(); ++i) {
      for (int k = 0; k < 3; ++k) index[3 * i + k] = static_cast<unsigned>(mesh_->triangles()[kept[i]][k]);
    }
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(scene_, geometry);
    rtcReleaseGeometry(geometry);
    device_->ThrowIfError("building the EmbreeTriangleScene geometry");
    rtcCommitScene(scene_);
    device_->ThrowIfError("rtcCommitScene (EmbreeTriangleScene)");
  } catch (...) {
    rtcReleaseScene(scene_);
    throw;
  }
}

EmbreeTriangleScene::~EmbreeTriangleScene() { rtcReleaseScene(scene_); }

geometry::SegmentMeshHit CastSegmentUnconfirmed(const EmbreeTriangleScene& scene, const Vector3& p,
                                                const Vector3& q) {
  if (!p.allFinite() || !q.allFinite() || p == q) return {};
  const Vector3 d = q - p;
  RTCRayHit ray{};
  ray.ray.org_x = static_cast<float>(p.x());
  ray.ray.org_y = static_cast<float>(p.y());
  ray.ray.org_z = static_cast<float>(p.z());
  ray.ray.dir_x = static_cast<float>(d.x());
  ray.ray.dir_y = static_cast<float>(d.y());
  ray.ray.dir_z = static_cast<float>(d.z());
  ray.ray.tnear = 0.0f;
  ray.ray.tfar = 1.0f;
  ray.ray.mask = ~0u;
  ray.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  rtcIntersect1(scene.scene(), &context, &ray);
  if (ray.hit.geomID == RTC_INVALID_GEOMETRY_ID) return {};
  return {true, ray.ray.tfar, scene.primitive_triangle(ray.hit.primID), ray.hit.u, ray.hit.v};
}

}  // namespace hapticd::embree
