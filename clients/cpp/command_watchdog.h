#pragma once
// The device side's watchdog: what a device renders when the server's commands stop.
//
// A fresh command is rendered as it is. Without one, the last command is held for
// hold_s (a lost packet or two must not be felt), then its force and torque ramp
// linearly to zero over ramp_s; an admittance device's position target is held (the
// handle stays where it was last sent). The next fresh command ends the ramp at once.
// The server runs the same watchdog on its side (its DeviceCommand flags say so); this
// one also covers a server or network that has gone silent altogether.
//
//   age = t - t_last_command:   [0, hold_s]         the last output as it is
//                               (hold_s, hold_s + ramp_s)   force x (1 - (age - hold_s) / ramp_s)
//                               >= hold_s + ramp_s  zero force, position held
#include <cstdint>

#include "clients/cpp/device_driver.h"

namespace hapticd::proxy {

class CommandWatchdog {
 public:
  // initial: what to render before the first command (zero force; an admittance
  // device's start position). hold_s >= 0 and ramp_s >= 0 (0: drop at once), s.
  CommandWatchdog(const DeviceOutput& initial, double hold_s, double ramp_s);

  // A fresh command at time t (s, the loop's clock): rendered from now on.
  void Accept(const DeviceOutput& command, double t);

  // What to render at time t (s, >= the last Accept's t). Counts a trip the first time
  // the hold runs out after a command (or after the start).
  DeviceOutput Output(double t);

  // How often the hold ran out.
  uint64_t trips() const { return trips_; }

 private:
  DeviceOutput last_;
  double last_t_ = 0;
  double hold_s_;
  double ramp_s_;
  bool tripped_ = false;
  uint64_t trips_ = 0;
};

}  // namespace hapticd::proxy
