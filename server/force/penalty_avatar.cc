#include "server/force/penalty_avatar.h"

#include <algorithm>

#include "server/query/scene_queries.h"

namespace hapticd::force {

AvatarForce CalcPenaltyForce(const scene::SceneSnapshot& scene, const Vector3& p_WD,
                             const Vector3& v_WD, double radius, bool force_shading) {
  AvatarForce out;
  out.avatar_W = p_WD;
  const query::SceneContact contact = query::FindDeepestContact(scene, p_WD, radius, 0);
  if (contact.object < 0 || !(contact.depth > 0)) return out;
  const scene::SceneObject& object = scene.object(contact.object);
  const scene::Material& material = object.material;
  Vector3 n = contact.normal_W;
  if (force_shading && material.force_shading) {
    n = query::CalcSceneShadingNormal(scene, contact.object, contact.triangle, contact.point_W, n);
  }
  const double normal_speed = (v_WD - object.CalcPointVelocity(contact.point_W)).dot(n);
  // a spring-damper that pushes, never pulls
  const double magnitude =
      std::max(0.0, material.stiffness * contact.depth - material.damping * normal_speed);
  out.f_W = magnitude * n;
  out.contact = true;
  out.object = contact.object;
  return out;
}

}  // namespace hapticd::force
