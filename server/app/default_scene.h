#pragma once
// The scene the server starts on when no scene file is given: a floor, three primitives
// and a mesh that must stay a mesh (a torus: no primitive or hull renders it within the
// tolerance), spread around the origin so a device starting above it finds each.
//   floor   plane, z = 0, normal +z
//   box     half extents 0.05 m, centred at (0.15, 0, 0.05)
//   ball    sphere r 0.05 m at (-0.15, 0, 0.05)
//   pillar  capsule r 0.02 m, half length 0.05 m, upright at (0, 0.15, 0.07)
//   ring    torus mesh, radii 0.04 m and 0.012 m, lying at (0, -0.15, 0.012)
// All 2000 N/m, no damping or friction.
#include <vector>
#include "server/scene/scene_builder.h"

namespace hapticd::app {

std::vector<scene::ObjectSpec> MakeDefaultScene();

}  // namespace hapticd::app
