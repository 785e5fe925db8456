#pragma once

// The proxy methods: god-object for a point avatar (Zilles & Salisbury 1995) and finger
// proxy for a sphere avatar (Ruspini, Kolarov & Khatib 1997). One implementation for
// both: a point is a sphere of radius 0.
//
// Each tick: carry the proxy with a kinematic object it rests on, move it towards the
// device without entering anything (MoveProxy), then
//  - force shading: aim the proxy at the point of the contact plane that lies from the
//    device along the interpolated (shading) normal, so the force follows the smooth
//    normal while the proxy stays on the true surface;
//  - friction (the friction cone of Harwin & Melder 2002): with the proxy's tangential
//    offset e from that frictionless target and the device's depth d below the
//    surface, a sticking proxy stays while |e| <= mu_s d (inside the static cone); past
//    it the proxy slides, trailing the device on the dynamic cone's edge |e| = mu_d d
//    (tangential force mu_d times the normal force) until the device comes back inside
//    the dynamic cone, where it sticks again;
//  - force: the coupling spring k (proxy - device), plus the material's damping
//    against the device's velocity along the normal, relative to the touched object.
// k, damping and friction come from the touched object's material.

#include <cstdint>

#include "server/force/avatar_force.h"
#include "server/force/proxy_solver.h"

namespace hapticd::force {


class ProxyAvatar {
 public:
  // radius >= 0 (0: god-object); force_shading: on meshes whose material allows it.
  ProxyAvatar(double radius, bool force_shading);
  // Puts the proxy at p_W (which should be outside every object).
  void Reset(const Vector3& p_W);
  // One tick of dt seconds: device at p_WD moving at v_WD. The tick's queries are asked
  // of near, gathered here around the proxy (what it held is replaced; a neighbourhood
  // of no capacity asks the scene). Real-time safe.
  AvatarForce Step(const scene::SceneSnapshot& scene, query::Neighbourhood& near, const Vector3& p_WD,
                   const Vector3& v_WD, double dt);
  const Vector3& proxy() const { return proxy_; }

 private:
  double radius_;
  bool force_shading_;
  Vector3 proxy_ = Vector3::Zero();
  bool sliding_ = false;  // on the dynamic cone (else sticking or free)
  uint64_t scene_version_ = 0;  // the snapshot of the last tick (0: none yet)
  Vector3 last_motion_ = Vector3::Zero();  // how the proxy moved in the last tick, m
};

}  // namespace hapticd::force
