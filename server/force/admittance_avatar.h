#pragma once

// Admittance mode: the sensed force drives a virtual mass-damper avatar,
//   m dv/dt = f_sensed - b v,
// integrated each tick (semi-implicitly, so any b >= 0 and dt are stable) and moved
// with the proxy's constrained motion, so it slides along the scene and never enters
// it. The velocity is then what the constraint allowed ((x_new - x_old) / dt): pushing
// into a wall leaves no velocity into it, and the avatar rests on the surface. The
// avatar's position is the pose the device must take.

#include <cstdint>

#include "server/force/avatar_force.h"
#include "server/force/session_settings.h"
#include "server/query/neighbourhood.h"
#include "server/scene/scene_snapshot.h"

namespace hapticd::force {

class AdmittanceAvatar {
 public:
  // radius >= 0; settings validated by the session; max_velocity (m/s, > 0) caps speed.
  AdmittanceAvatar(double radius, const AdmittanceSettings& settings, double max_velocity);
  void Reset(const Vector3& p_W);
  // One tick of dt seconds under the sensed force, its queries asked of near (gathered
  // here around the avatar, as ProxyAvatar::Step does). Real-time safe. f_W in the
  // result is the sensed force; avatar_W the commanded position.
  AvatarForce Step(const scene::SceneSnapshot& scene, query::Neighbourhood& near, const Vector3& f_sensed_W,
                   double dt);
  const Vector3& position() const { return position_; }
  const Vector3& velocity() const { return velocity_; }

 private:
  double radius_;
  AdmittanceSettings settings_;
  double max_velocity_;
  Vector3 position_ = Vector3::Zero();
  Vector3 velocity_ = Vector3::Zero();
  uint64_t scene_version_ = 0;  // the snapshot of the last tick (0: none yet)
};

}  // namespace hapticd::force
