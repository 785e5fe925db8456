#include "server/force/session_settings.h"

#include <charconv>
#include <cmath>

namespace hapticd::force {
namespace {

// The shortest spelling of value that reads back to it ("0", "0.01", "nan", "-inf").
std::string FormatNumber(double value) {
  char buffer[32];
  const auto end = std::to_chars(buffer, buffer + sizeof(buffer), value).ptr;
  return std::string(buffer, end);
}

// "<field> is <value>; <requirement>".
std::string Complaint(std::string_view field, double value, std::string_view requirement) {
  return std::string(field) + " is " + FormatNumber(value) + "; " + std::string(requirement);
}

// A finite value > 0 (NaN and both infinities fail).
std::optional<std::string> CheckPositive(std::string_view field, double value) {
  if (std::isfinite(value) && value > 0) return std::nullopt;
  return Complaint(field, value, "it must be a finite number > 0");
}

// A finite value in [low, high] ("it must be in [10, 10000]").
std::optional<std::string> CheckRange(std::string_view field, double value, double low, double high) {
  if (value >= low && value <= high) return std::nullopt;
  return Complaint(field, value, "it must be in [" + FormatNumber(low) + ", " + FormatNumber(high) + "]");
}

// A finite value in (0, high].
std::optional<std::string> CheckPositiveAtMost(std::string_view field, double value, double high) {
  if (auto error = CheckPositive(field, value)) return error;
  if (value <= high) return std::nullopt;
  return Complaint(field, value, "it must be at most " + FormatNumber(high));
}

using L = SessionLimits;

// An enum whose value is outside its enumerators, spelled as its integer.
std::string UnknownEnum(std::string_view field, int value, std::string_view known) {
  return std::string(field) + " is " + std::to_string(value) + ", which is not " +
         std::string(known);
}

std::optional<std::string> ValidateAvatar(const AvatarSettings& avatar) {
  // the type must be one of the enumerators
  if (AvatarTypeName(avatar.type).empty())
    return UnknownEnum("avatar.type", static_cast<int>(avatar.type), "point or sphere");

  // a point has no radius, a sphere a finite positive one
  if (avatar.type == AvatarType::kPoint && avatar.radius != 0)
    return Complaint("avatar.radius", avatar.radius, "a point avatar has radius 0");
  if (avatar.type == AvatarType::kSphere && std::isinf(avatar.radius))
    return Complaint("avatar.radius", avatar.radius, "a sphere avatar needs a finite radius");
  if (avatar.type == AvatarType::kSphere && !(avatar.radius > 0))
    return Complaint("avatar.radius", avatar.radius, "a sphere avatar needs a radius > 0");
  if (avatar.type == AvatarType::kSphere && avatar.radius > L::kMaxAvatarRadius)
    return Complaint("avatar.radius", avatar.radius,
                     "a sphere avatar's radius must be at most " + FormatNumber(L::kMaxAvatarRadius) + " m");

  // the method must exist and suit the avatar; penalty suits both
  switch (avatar.method) {
    case ForceMethod::kPenalty:
      return std::nullopt;
    case ForceMethod::kGodObject:
      if (avatar.type == AvatarType::kPoint) return std::nullopt;
      return "avatar.method is god_object, which needs a point avatar";
    case ForceMethod::kFingerProxy:
      if (avatar.type == AvatarType::kSphere) return std::nullopt;
      return "avatar.method is finger_proxy, which needs a sphere avatar";
  }
  return UnknownEnum("avatar.method", static_cast<int>(avatar.method),
                     "penalty, god_object or finger_proxy");
}

std::optional<std::string> ValidateDevice(const DeviceSettings& device) {
  if (DeviceModeName(device.mode).empty())
    return UnknownEnum("device.mode", static_cast<int>(device.mode),
                       "impedance or admittance");
  if (auto error = CheckPositiveAtMost("device.max_force", device.max_force, L::kMaxForce)) return error;
  // an infinite rate means no rate limit
  if (!(device.max_force_rate > 0))
    return Complaint("device.max_force_rate", device.max_force_rate,
                     "it must be a number > 0 (inf: no limit)");
  if (auto error = CheckPositiveAtMost("device.max_velocity", device.max_velocity, L::kMaxVelocity))
    return error;
  return CheckRange("device.rate_hz", device.rate_hz, L::kMinRateHz, L::kMaxRateHz);
}

std::optional<std::string> ValidateAdmittance(const AdmittanceSettings& admittance) {
  if (auto error = CheckRange("admittance.virtual_mass", admittance.virtual_mass, L::kMinVirtualMass,
                              L::kMaxVirtualMass))
    return error;
  return CheckRange("admittance.virtual_damping", admittance.virtual_damping, 0, L::kMaxVirtualDamping);
}

std::optional<std::string> ValidateControl(const ControlSettings& control) {
  if (auto error = CheckPositiveAtMost("control.watchdog_timeout_s", control.watchdog_timeout_s,
                                       L::kMaxWatchdogS))
    return error;
  return CheckPositiveAtMost("control.watchdog_ramp_s", control.watchdog_ramp_s, L::kMaxWatchdogS);
}

}  // namespace

std::optional<std::string> ValidateSessionSettings(const SessionSettings& settings) {
  // the sections in declaration order; the first bad field wins
  if (auto error = ValidateAvatar(settings.avatar)) return error;
  if (auto error = ValidateDevice(settings.device)) return error;
  // checked in impedance mode too, so that a later switch of mode cannot surprise
  if (auto error = ValidateAdmittance(settings.admittance)) return error;
  return ValidateControl(settings.control);
}

// An enum value outside the enumerators has no name: the empty string.
std::string_view ForceMethodName(ForceMethod method) {
  switch (method) {
    case ForceMethod::kPenalty:
      return "penalty";
    case ForceMethod::kGodObject:
      return "god_object";
    case ForceMethod::kFingerProxy:
      return "finger_proxy";
  }
  return "";
}

std::string_view AvatarTypeName(AvatarType type) {
  switch (type) {
    case AvatarType::kPoint:
      return "point";
    case AvatarType::kSphere:
      return "sphere";
  }
  return "";
}

std::string_view DeviceModeName(DeviceMode mode) {
  switch (mode) {
    case DeviceMode::kImpedance:
      return "impedance";
    case DeviceMode::kAdmittance:
      return "admittance";
  }
  return "";
}

}  // namespace hapticd::force
