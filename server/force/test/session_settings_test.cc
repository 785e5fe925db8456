#include "server/force/session_settings.h"

#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace hapticd::force {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

SessionSettings Sphere(double radius, ForceMethod method) {
  SessionSettings settings;
  settings.avatar.type = AvatarType::kSphere;
  settings.avatar.radius = radius;
  settings.avatar.method = method;
  return settings;
}

SessionSettings Point(ForceMethod method) {
  SessionSettings settings;
  settings.avatar.method = method;
  return settings;
}

// The message for settings, or "ok".
std::string Check(const SessionSettings& settings) {
  return ValidateSessionSettings(settings).value_or("ok");
}

TEST(SessionSettingsTest, DefaultsAreValid) {
  EXPECT_EQ(Check(SessionSettings{}), "ok");
}

// Penalty suits both avatars, god-object a point, finger proxy a sphere.
TEST(SessionSettingsTest, MethodsAndAvatars) {
  EXPECT_EQ(Check(Point(ForceMethod::kGodObject)), "ok");
  EXPECT_EQ(Check(Point(ForceMethod::kPenalty)), "ok");
  EXPECT_EQ(Check(Sphere(0.01, ForceMethod::kPenalty)), "ok");
  EXPECT_EQ(Check(Sphere(0.01, ForceMethod::kFingerProxy)), "ok");
  EXPECT_EQ(Check(Sphere(0.01, ForceMethod::kGodObject)),
            "avatar.method is god_object, which needs a point avatar");
  EXPECT_EQ(Check(Point(ForceMethod::kFingerProxy)),
            "avatar.method is finger_proxy, which needs a sphere avatar");
}

TEST(SessionSettingsTest, AvatarRadius) {
  EXPECT_EQ(Check(Sphere(0, ForceMethod::kFingerProxy)),
            "avatar.radius is 0; a sphere avatar needs a radius > 0");
  EXPECT_EQ(Check(Sphere(-0.5, ForceMethod::kPenalty)),
            "avatar.radius is -0.5; a sphere avatar needs a radius > 0");
  EXPECT_EQ(Check(Sphere(kNaN, ForceMethod::kFingerProxy)),
            "avatar.radius is nan; a sphere avatar needs a radius > 0");
  EXPECT_EQ(Check(Sphere(kInf, ForceMethod::kFingerProxy)),
            "avatar.radius is inf; a sphere avatar needs a finite radius");
  // a point has none
  SessionSettings point = Point(ForceMethod::kGodObject);
  point.avatar.radius = 0.01;
  EXPECT_EQ(Check(point), "avatar.radius is 0.01; a point avatar has radius 0");
  point.avatar.radius = kNaN;
  EXPECT_EQ(Check(point), "avatar.radius is nan; a point avatar has radius 0");
  // the radius is checked before the method
  EXPECT_EQ(Check(Sphere(0, ForceMethod::kGodObject)),
            "avatar.radius is 0; a sphere avatar needs a radius > 0");
}

// Each numeric field, set alone to a bad value, is named with that value.
TEST(SessionSettingsTest, EachNumericFieldIsNamed) {
  struct Case {
    std::function<void(SessionSettings&)> set;
    std::string expected;
  };
  const std::string positive = "; it must be a finite number > 0";
  const std::vector<Case> cases = {
      {[](SessionSettings& s) { s.device.max_force = 0; },
       "device.max_force is 0" + positive},
      {[](SessionSettings& s) { s.device.max_force = kNaN; },
       "device.max_force is nan" + positive},
      {[](SessionSettings& s) { s.device.max_force = kInf; },
       "device.max_force is inf" + positive},
      {[](SessionSettings& s) { s.device.max_force = -3; },
       "device.max_force is -3" + positive},
      {[](SessionSettings& s) { s.device.max_force_rate = 0; },
       "device.max_force_rate is 0; it must be a number > 0 (inf: no limit)"},
      {[](SessionSettings& s) { s.device.max_force_rate = -kInf; },
       "device.max_force_rate is -inf; it must be a number > 0 (inf: no limit)"},
      {[](SessionSettings& s) { s.device.max_force_rate = kNaN; },
       "device.max_force_rate is nan; it must be a number > 0 (inf: no limit)"},
      {[](SessionSettings& s) { s.device.max_velocity = 0; },
       "device.max_velocity is 0" + positive},
      {[](SessionSettings& s) { s.device.max_velocity = kNaN; },
       "device.max_velocity is nan" + positive},
      {[](SessionSettings& s) { s.device.rate_hz = -1000; },
       "device.rate_hz is -1000; it must be in [10, 10000]"},
      {[](SessionSettings& s) { s.device.rate_hz = kInf; },
       "device.rate_hz is inf; it must be in [10, 10000]"},
      {[](SessionSettings& s) { s.admittance.virtual_mass = 0; },
       "admittance.virtual_mass is 0; it must be in [0.001, 1000]"},
      {[](SessionSettings& s) { s.admittance.virtual_mass = kNaN; },
       "admittance.virtual_mass is nan; it must be in [0.001, 1000]"},
      {[](SessionSettings& s) { s.admittance.virtual_damping = -0.1; },
       "admittance.virtual_damping is -0.1; it must be in [0, 1e+05]"},
      {[](SessionSettings& s) { s.admittance.virtual_damping = kNaN; },
       "admittance.virtual_damping is nan; it must be in [0, 1e+05]"},
      {[](SessionSettings& s) { s.control.watchdog_timeout_s = 0; },
       "control.watchdog_timeout_s is 0" + positive},
      {[](SessionSettings& s) { s.control.watchdog_timeout_s = kNaN; },
       "control.watchdog_timeout_s is nan" + positive},
      {[](SessionSettings& s) { s.control.watchdog_ramp_s = -0.25; },
       "control.watchdog_ramp_s is -0.25" + positive},
      {[](SessionSettings& s) { s.control.watchdog_ramp_s = kInf; },
       "control.watchdog_ramp_s is inf" + positive},
  };
  for (const Case& c : cases) {
    SessionSettings settings;
    c.set(settings);
    EXPECT_EQ(Check(settings), c.expected);
  }
}

// The boundary values that are allowed.
TEST(SessionSettingsTest, AllowedEdges) {
  SessionSettings settings;
  settings.device.max_force_rate = kInf;  // no rate limit
  settings.admittance.virtual_damping = 0;
  settings.avatar.radius = -0.0;  // a point's radius, signed zero
  EXPECT_EQ(Check(settings), "ok");
  settings.device.max_force = 1e-9;
  settings.device.max_force_rate = 1e-9;
  settings.device.mode = DeviceMode::kAdmittance;
  EXPECT_EQ(Check(settings), "ok");
}

// With several bad fields the first in declaration order is reported.
TEST(SessionSettingsTest, FirstBadFieldWins) {
  SessionSettings settings = Sphere(0, ForceMethod::kGodObject);
  settings.device.max_force = kNaN;
  settings.control.watchdog_ramp_s = 0;
  EXPECT_EQ(Check(settings), "avatar.radius is 0; a sphere avatar needs a radius > 0");
  settings.avatar.radius = 0.02;
  settings.avatar.method = ForceMethod::kPenalty;
  EXPECT_EQ(Check(settings), "device.max_force is nan; it must be a finite number > 0");
  settings.device.max_force = 5;
  EXPECT_EQ(Check(settings), "control.watchdog_ramp_s is 0; it must be a finite number > 0");
}

// Enum values outside the enumerators (a bad cast upstream) are named, not trusted.
TEST(SessionSettingsTest, UnknownEnumValues) {
  SessionSettings settings;
  settings.avatar.type = static_cast<AvatarType>(7);
  EXPECT_EQ(Check(settings), "avatar.type is 7, which is not point or sphere");
  settings = SessionSettings{};
  settings.avatar.method = static_cast<ForceMethod>(-1);
  EXPECT_EQ(Check(settings),
            "avatar.method is -1, which is not penalty, god_object or finger_proxy");
  settings = SessionSettings{};
  settings.device.mode = static_cast<DeviceMode>(2);
  EXPECT_EQ(Check(settings), "device.mode is 2, which is not impedance or admittance");
}

TEST(SessionSettingsTest, Names) {
  EXPECT_EQ(ForceMethodName(ForceMethod::kPenalty), "penalty");
  EXPECT_EQ(ForceMethodName(ForceMethod::kGodObject), "god_object");
  EXPECT_EQ(ForceMethodName(ForceMethod::kFingerProxy), "finger_proxy");
  EXPECT_EQ(AvatarTypeName(AvatarType::kPoint), "point");
  EXPECT_EQ(AvatarTypeName(AvatarType::kSphere), "sphere");
  EXPECT_EQ(DeviceModeName(DeviceMode::kImpedance), "impedance");
  EXPECT_EQ(DeviceModeName(DeviceMode::kAdmittance), "admittance");
  // no name for a value outside the enumerators
  EXPECT_EQ(ForceMethodName(static_cast<ForceMethod>(3)), "");
  EXPECT_EQ(AvatarTypeName(static_cast<AvatarType>(2)), "");
  EXPECT_EQ(DeviceModeName(static_cast<DeviceMode>(-4)), "");
}

}  // namespace
}  // namespace hapticd::force
