#pragma once

// How an object feels: its surface stiffness and damping, and its friction.

#include <optional>
#include <string>
#include <string_view>

namespace hapticd::scene {

struct Material {
  double stiffness = 1000;         // N/m, > 0
  double damping = 0;              // N·s/m, >= 0 (along the surface normal)
  double static_friction = 0;      // >= 0, the friction cone's half-angle is atan(mu)
  double dynamic_friction = 0;     // >= 0 and <= static_friction
  bool force_shading = true;       // render with interpolated vertex normals (meshes)
};

// Nullopt when the material is usable, else a message naming the first bad field as
// `field`.stiffness etc. and its value, e.g. "objects[2].material.stiffness is -5; it
// must be a finite number > 0".
std::optional<std::string> ValidateMaterial(const Material& material, std::string_view field);

}  // namespace hapticd::scene
