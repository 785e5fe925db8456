#pragma once

// The penalty method, the simple baseline: force from how deep the device is inside an
// object. It needs no state, and it is what pops through thin objects: once the device
// is past an object's middle, the nearest surface is the far one.

#include "server/force/avatar_force.h"
#include "server/scene/scene_snapshot.h"

namespace hapticd::force {

// Penalty: a spring-damper on the device's penetration (the device point, or a sphere
// of radius at it) into the object it penetrates deepest: F = (k d - b v_n) n, never
// pulling (F . n >= 0). Stateless. With force_shading, n is the shading normal.
AvatarForce CalcPenaltyForce(const scene::SceneSnapshot& scene, const Vector3& p_WD,
                             const Vector3& v_WD, double radius, bool force_shading);

}  // namespace hapticd::force
