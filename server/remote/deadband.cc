#include "server/remote/deadband.h"

#include <cmath>

#include <fmt/format.h>

namespace hapticd::remote {
namespace {

// Nullopt when value is in (0, high]; else a message naming field, value and the range.
std::optional<std::string> CheckPositive(double value, double high, const char* field) {
  if (value > 0 && value <= high) return std::nullopt;
  return fmt::format("{} is {}; it must be in (0, {}]", field, value, high);
}

}  // namespace

std::optional<std::string> ValidateDeadband(const DeadbandSettings& settings) {
  if (!(settings.weber >= 0 && settings.weber < 1)) {
    return fmt::format("deadband is {}; a Weber fraction must be in [0, 1) (0: off)", settings.weber);
  }
  if (auto error = CheckPositive(settings.force_floor_n, kMaxForceFloorN, "deadband_force_floor")) return error;
  if (auto error = CheckPositive(settings.position_floor_m, kMaxPositionFloorM, "deadband_position_floor")) {
    return error;
  }
  if (auto error = CheckPositive(settings.velocity_floor_mps, kMaxVelocityFloorMps, "deadband_velocity_floor")) {
    return error;
  }
  if (auto error = CheckPositive(settings.keepalive_s, kMaxKeepaliveS, "keepalive_s")) {
    return *error + " (half the server's 50 ms watchdog at most)";
  }
  return std::nullopt;
}

}  // namespace hapticd::remote
