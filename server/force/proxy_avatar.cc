#include "server/force/proxy_avatar.h"

#include <algorithm>
#include <cmath>

#include "server/query/scene_queries.h"

namespace hapticd::force {
namespace {

// Below this cosine between the shading and the true normal, shading would aim the
// proxy too far along the surface: render the true normal instead.
constexpr double kMinShadingCosine = 0.2;

// The constraint plane that holds the device back most (deepest below it).
const ProxyPlane& DeepestPlane(const ProxyMove& move, const Vector3& p_WD) {
  int deepest = 0;
  for (int i = 1; i < move.num_planes; ++i) {
    const double depth = move.planes[i].offset - move.planes[i].normal.dot(p_WD);
    if (depth > move.planes[deepest].offset - move.planes[deepest].normal.dot(p_WD)) deepest = i;
  }
  return move.planes[deepest];
}

}  // namespace

ProxyAvatar::ProxyAvatar(double radius, bool force_shading)
    : radius_(radius), force_shading_(force_shading) {}

void ProxyAvatar::Reset(const Vector3& p_W) {
  proxy_ = p_W;
  sliding_ = false;
  scene_version_ = 0;
  last_motion_.setZero();
}

AvatarForce ProxyAvatar::Step(const scene::SceneSnapshot& scene, query::Neighbourhood& near, const Vector3& p_WD,
                              const Vector3& v_WD, double dt) {
  AvatarForce out;
  // what this tick's queries can reach: the proxy goes on about as it went last tick,
  // and no farther than the device is from it
  const Vector3 proxy_before = proxy_;
  const double step = last_motion_.norm();
  const double reach = (p_WD - proxy_).norm();
  GatherAlong(scene, near, proxy_, radius_, step > reach ? Vector3(last_motion_ * (reach / step)) : last_motion_);
  const Vector3 start = CarryProxy(near, proxy_, radius_, dt, scene.version() != scene_version_);
  scene_version_ = scene.version();
  const ProxyMove free_move = MoveProxy(near, start, p_WD, radius_);
  out.overflow = free_move.overflow;
  proxy_ = free_move.position;
  out.avatar_W = proxy_;
  if (free_move.num_planes == 0) {
    sliding_ = false;
    last_motion_ = proxy_ - proxy_before;
    return out;
  }

  // the surface that holds the device back, and its material
  const ProxyPlane& plane = DeepestPlane(free_move, p_WD);
  const scene::SceneObject& object = scene.object(plane.object);
  const scene::Material& material = object.material;
  const Vector3& n = plane.normal;
  const double depth = plane.offset - n.dot(p_WD);
  Vector3 target = free_move.position;

  // force shading: the point of the contact plane seen from the device along the
  // shading normal
  if (force_shading_ && material.force_shading && free_move.num_planes == 1 && depth > 0) {
    const Vector3 shading =
        query::CalcSceneShadingNormal(scene, plane.object, plane.triangle, plane.point_W, n);
    const double cosine = shading.dot(n);
    if (cosine > kMinShadingCosine) target = p_WD + (depth / cosine) * shading;
  }

  // friction cone (Harwin & Melder 2002): a sticking proxy holds while the device
  // stays inside the static cone and breaks free beyond it; a sliding proxy trails the
  // device on the dynamic cone's edge until the device comes back inside that cone
  bool sliding = false;
  if (material.static_friction > 0 && depth > 0) {
    Vector3 offset = start - target;
    offset -= n.dot(offset) * n;
    const double slip = offset.norm();
    const double cone = (sliding_ ? material.dynamic_friction : material.static_friction) * depth;
    if (slip <= cone) {
      target += offset;
    } else {
      target += (material.dynamic_friction * depth / slip) * offset;
      sliding = true;
    }
  }
  sliding_ = sliding;

  if (target != free_move.position) {
    const ProxyMove held = MoveProxy(near, start, target, radius_);
    out.overflow = out.overflow || held.overflow;
    proxy_ = held.position;
    out.avatar_W = proxy_;
  }
  last_motion_ = proxy_ - proxy_before;

  // the coupling spring, and damping along the normal relative to the object
  out.contact = true;
  out.object = plane.object;
  const Vector3 v_relative = v_WD - object.CalcPointVelocity(plane.point_W);
  const double normal_speed = v_relative.dot(n);
  out.f_W = material.stiffness * (proxy_ - p_WD);
  if (depth > 0) out.f_W -= material.damping * normal_speed * n;
  return out;
}

}  // namespace hapticd::force
