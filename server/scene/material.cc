#include "server/scene/material.h"

#include <cmath>

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
  // stiffness: a spring that pushes back
  if (!(material.stiffness > 0) || !std::isfinite(material.stiffness)) {
    return Complaint(field, "stiffness", material.stiffness, "a finite number > 0");
  }
  // damping: dissipative or none, never negative (that would inject energy)
  if (!(material.damping >= 0) || !std::isfinite(material.damping)) {
    return Complaint(field, "damping", material.damping, "a finite number >= 0");
  }
  if (!(material.static_friction >= 0) || !std::isfinite(material.static_friction)) {
    return Complaint(field, "static_friction", material.static_friction, "a finite number >= 0");
  }
  if (!(material.dynamic_friction >= 0) || !std::isfinite(material.dynamic_friction)) {
    return Complaint(field, "dynamic_friction", material.dynamic_friction,
                     "a finite number >= 0");
  }
  // sliding never holds more than sticking
  if (material.dynamic_friction > material.static_friction) {
    return Complaint(field, "dynamic_friction", material.dynamic_friction,
                     "<= static_friction (" + FormatExact(material.static_friction) + ")");
  }
  return std::nullopt;
}

}  // namespace hapticd::scene
