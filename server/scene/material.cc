#include "server/scene/material.h"

#include <cmath>

#include "server/scene/scene_limits.h"
#include "server/scene/value_text.h"

namespace hapticd::scene {
namespace {

// "<field>.<name> is <value>; it must be <rule>".
std::string Complaint(std::string_view field, std::string_view name, double value,
                      std::string_view rule) {
  return std::string(field) + "." + std::string(name) + " is " + FormatExact(value) +
         "; it must be " + std::string(rule);
}

}  // namespace

std::optional<std::string> ValidateMaterial(const Material& material, std::string_view field) {
  using L = SceneLimits;
  // stiffness: a spring that pushes back
  if (!(material.stiffness > 0) || !(material.stiffness <= L::kMaxStiffness)) {
    return Complaint(field, "stiffness", material.stiffness, "in (0, " + FormatExact(L::kMaxStiffness) + "] N/m");
  }
  // damping: dissipative or none, never negative (that would inject energy)
  if (!(material.damping >= 0) || !(material.damping <= L::kMaxDamping)) {
    return Complaint(field, "damping", material.damping, "in [0, " + FormatExact(L::kMaxDamping) + "] N*s/m");
  }
  const std::string friction_range = "in [0, " + FormatExact(L::kMaxFriction) + "]";
  if (!(material.static_friction >= 0) || !(material.static_friction <= L::kMaxFriction)) {
    return Complaint(field, "static_friction", material.static_friction, friction_range);
  }
  if (!(material.dynamic_friction >= 0) || !(material.dynamic_friction <= L::kMaxFriction)) {
    return Complaint(field, "dynamic_friction", material.dynamic_friction, friction_range);
  }
  // sliding never holds more than sticking
  if (material.dynamic_friction > material.static_friction) {
    return Complaint(field, "dynamic_friction", material.dynamic_friction,
                     "<= static_friction (" + FormatExact(material.static_friction) + ")");
  }
  return std::nullopt;
}

}  // namespace hapticd::scene
