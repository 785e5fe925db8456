#include "clients/cpp/command_watchdog.h"

#include <algorithm>

namespace hapticd::proxy {

CommandWatchdog::CommandWatchdog(const DeviceOutput& initial, double hold_s, double ramp_s)
    : last_(initial), hold_s_(hold_s), ramp_s_(ramp_s) {}

void CommandWatchdog::Accept(const DeviceOutput& command, double t) {
  last_ = command;
  last_t_ = t;
  tripped_ = false;
}

DeviceOutput CommandWatchdog::Output(double t) {
  const double age = t - last_t_;
  // fresh enough: the last command as it is
  if (age <= hold_s_) return last_;
  if (!tripped_) {
    tripped_ = true;
    ++trips_;
  }
  // ramping, or done (a zero ramp drops at once); the position target stays
  const double scale = ramp_s_ > 0 ? std::clamp(1 - (age - hold_s_) / ramp_s_, 0.0, 1.0) : 0.0;
  DeviceOutput output = last_;
  output.f_W *= scale;
  output.tau_W *= scale;
  return output;
}

}  // namespace hapticd::proxy
