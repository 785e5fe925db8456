#include "server/force/admittance_avatar.h"

#include "server/force/proxy_solver.h"

namespace hapticd::force {

AdmittanceAvatar::AdmittanceAvatar(double radius, const AdmittanceSettings& settings,
                                   double max_velocity)
    : radius_(radius), settings_(settings), max_velocity_(max_velocity) {}

void AdmittanceAvatar::Reset(const Vector3& p_W) {
  position_ = p_W;
  velocity_.setZero();
  scene_version_ = 0;
}

AvatarForce AdmittanceAvatar::Step(const scene::SceneSnapshot& scene, query::Neighbourhood& near,
                                   const Vector3& f_sensed_W, double dt) {
  AvatarForce out;
  out.f_W = f_sensed_W;
  // semi-implicit mass-damper step: v' = (m v + dt f) / (m + dt b)
  const double m = settings_.virtual_mass;
  velocity_ = (m * velocity_ + dt * f_sensed_W) / (m + dt * settings_.virtual_damping);
  const double speed = velocity_.norm();
  if (speed > max_velocity_) velocity_ *= max_velocity_ / speed;

  // move under the scene's constraints; the velocity is what they allowed
  // what this tick's queries can reach: the step the velocity takes (and a carry)
  GatherAlong(scene, near, position_, radius_, dt * velocity_);
  const Vector3 start = CarryProxy(near, position_, radius_, dt, scene.version() != scene_version_);
  scene_version_ = scene.version();
  const ProxyMove move = MoveProxy(near, start, start + dt * velocity_, radius_);
  velocity_ = (move.position - position_) / dt;
  position_ = move.position;
  out.avatar_W = position_;
  out.contact = move.num_planes > 0;
  out.object = move.num_planes > 0 ? move.planes[0].object : -1;
  out.overflow = move.overflow;
  return out;
}

}  // namespace hapticd::force
