#include "server/query/neighbourhood.h"

#include <algorithm>
#include <cmath>

#include "server/geometry/aabb.h"
#include "server/geometry/work_meter.h"

namespace hapticd::query {
namespace {

bool IsBounded(const geometry::Aabb& bounds) {
  return !bounds.empty() && bounds.min.allFinite() && bounds.max.allFinite();
}

}  // namespace

Neighbourhood::Neighbourhood(const scene::SceneSnapshot& scene) : scene_(&scene) {}

Neighbourhood::Neighbourhood(int max_objects, int max_triangles)
    : objects_(std::max(max_objects, 0)), triangles_(std::max(max_triangles, 0)) {}

void Neighbourhood::Gather(const scene::SceneSnapshot& scene, const Vector3& a_W, const Vector3& b_W, double radius,
                           bool triangles) {
  scene_ = &scene;
  region_W_ = {a_W, b_W, -1};
  num_objects_ = 0;
  num_triangles_ = 0;
  if (!a_W.allFinite() || !b_W.allFinite() || !(radius >= 0) || !std::isfinite(radius) || objects_.empty()) return;
  // the objects whose bounds lie within radius of the segment's box, while they fit (a
  // few more than the region's: nothing is lost by asking them)
  bool fits = true;
  const geometry::Aabb segment_box{a_W.cwiseMin(b_W), a_W.cwiseMax(b_W)};
  scene.ForEachObjectNear(segment_box.Inflated(radius), near_cache_, [&](int i) {
    if (!geometry::WorkMeter::Charge(1)) return fits = false;
    const scene::SceneObject& object = scene.object(i);
    if (geometry::CalcAabbAabbDistanceSquared(object.bounds_W, segment_box) > radius * radius) return true;
    if (num_objects_ == static_cast<int>(objects_.size())) return fits = false;
    objects_[num_objects_++] = {i, IsBounded(object.bounds_W), {}};
    return true;
  });
  if (!fits) {
    num_objects_ = 0;
    return;
  }
  // in scene order, as the scene's queries break their ties
  std::sort(objects_.begin(), objects_.begin() + num_objects_,
            [](const Object& x, const Object& y) { return x.index < y.index; });
  // each mesh's triangles there, where they fit in what is left
  for (int k = 0; k < num_objects_ && triangles; ++k) {
    const scene::SceneObject& object = scene.object(objects_[k].index);
    const auto* mesh = std::get_if<scene::MeshShape>(&object.shape);
    if (mesh == nullptr) continue;
    const geometry::Capsule region_B{object.X_WB.ToBody(a_W), object.X_WB.ToBody(b_W), radius};
    const std::span<geometry::PreparedTriangle> free =
        std::span(triangles_).subspan(static_cast<size_t>(num_triangles_));
    const int found = geometry::GatherMeshTriangles(*mesh->bvh, region_B, free);
    if (found > static_cast<int>(free.size())) continue;
    objects_[k].mesh = {free.first(static_cast<size_t>(found)), region_B};
    num_triangles_ += found;
  }
  // a spent work budget cut a walk short: what was gathered is not all there is (and
  // the tick is thrown away)
  if (geometry::WorkMeter::Exhausted()) {
    num_objects_ = num_triangles_ = 0;
    return;
  }
  region_W_.radius = radius;
}

}  // namespace hapticd::query
