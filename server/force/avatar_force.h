#pragma once

// What a force method computes in one tick, whichever method it is.

#include "server/geometry/types.h"

namespace hapticd::force {

using geometry::Vector3;

struct AvatarForce {
  Vector3 f_W = Vector3::Zero();       // force on the device, N
  Vector3 avatar_W = Vector3::Zero();  // the proxy (or the device point for penalty)
  bool contact = false;
  int object = -1;
  bool overflow = false;  // the proxy met more constraints than it can hold this tick
};

}  // namespace hapticd::force
