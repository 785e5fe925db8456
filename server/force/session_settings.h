#pragma once

// What a render session is asked to do: its avatar and force method, what the device
// can render, and which control layers run. Validated once, when the session opens.

#include <limits>
#include <optional>
#include <string>
#include <string_view>

namespace hapticd::force {

enum class AvatarType { kPoint, kSphere };
enum class ForceMethod {
  kPenalty,      // spring-damper on the device point's (or sphere's) penetration
  kGodObject,    // point avatar, Zilles & Salisbury 1995
  kFingerProxy,  // sphere avatar, Ruspini, Kolarov & Khatib 1997
};
enum class DeviceMode {
  kImpedance,   // position in, force out
  kAdmittance,  // sensed force in, pose out
};

struct AvatarSettings {
  AvatarType type = AvatarType::kPoint;
  double radius = 0;  // m; 0 for a point, > 0 for a sphere
  ForceMethod method = ForceMethod::kGodObject;
  bool force_shading = false;  // interpolated normals on meshes whose material allows it
};

struct DeviceSettings {
  DeviceMode mode = DeviceMode::kImpedance;
  double max_force = 10;  // N, > 0: the rendered force is saturated to this
  // N/s, > 0: how fast the rendered force may change (infinite: no limit).
  double max_force_rate = std::numeric_limits<double>::infinity();
  // m/s, > 0: admittance avatars are limited to this speed; impedance input faster than
  // 10x this is counted as absurd.
  double max_velocity = 2.0;
  double rate_hz = 1000;  // in [SessionLimits::kMinRateHz, kMaxRateHz]
};

// Admittance mode: the avatar is a virtual mass-damper driven by the sensed force.
struct AdmittanceSettings {
  double virtual_mass = 1.0;     // kg, > 0
  double virtual_damping = 20;   // N·s/m, >= 0
};

struct ControlSettings {
  bool passivity = false;  // passivity observer and controller (Hannaford & Ryu 2002)
  // No fresh device input for this long (s, > 0) trips the watchdog, which then ramps
  // the force to zero over ramp_s (s, > 0).
  double watchdog_timeout_s = 0.05;
  double watchdog_ramp_s = 0.1;
};

struct SessionSettings {
  AvatarSettings avatar;
  DeviceSettings device;
  AdmittanceSettings admittance;
  ControlSettings control;
};

// The range of every setting a client or a scenario controls, checked by
// ValidateSessionSettings: wide enough for every device hapticd serves (desktop devices
// at 1-10 kHz, a UR arm at 125-500 Hz), narrow enough that every value that passes
// keeps a tick's arithmetic finite and meaningful.
struct SessionLimits {
  static constexpr double kMinRateHz = 10;  // the period is the integration step's bound
  static constexpr double kMaxRateHz = 10'000;
  static constexpr double kMaxAvatarRadius = 1;         // m
  static constexpr double kMaxForce = 10'000;           // N (max_force)
  static constexpr double kMaxVelocity = 100;           // m/s (max_velocity)
  static constexpr double kMinVirtualMass = 1e-3;       // kg
  static constexpr double kMaxVirtualMass = 1e3;        // kg
  static constexpr double kMaxVirtualDamping = 1e5;     // N·s/m
  static constexpr double kMaxWatchdogS = 10;           // s (timeout and ramp each)
};

// Nullopt when usable; else a message naming the first bad field ("avatar.radius is 0;
// a sphere avatar needs a radius > 0", "avatar.method is god_object, which needs a
// point avatar").
std::optional<std::string> ValidateSessionSettings(const SessionSettings& settings);

// Names as the scenario format and protocol spell them: "penalty", "god_object",
// "finger_proxy"; "point", "sphere"; "impedance", "admittance".
std::string_view ForceMethodName(ForceMethod method);
std::string_view AvatarTypeName(AvatarType type);
std::string_view DeviceModeName(DeviceMode mode);

}  // namespace hapticd::force
