#pragma once

// An Embree device with its error callback registered from the start (Embree calls
// it on every failing API call, from whichever thread made the call). The callback
// records the last error and counts them; the scene builders turn a recorded error
// into an exception that names the failing call and carries Embree's message.
//
// Creating devices and building scenes is setup work, off the real-time thread; a
// query on a committed scene never reports errors (Embree does not check queries).

#include <embree3/rtcore.h>

#include <mutex>
#include <string>
#include <string_view>

namespace hapticd::embree {

// An error Embree reported: the code (RTC_ERROR_NONE when there was none) and its text.
struct DeviceError {
  RTCError code = RTC_ERROR_NONE;
  std::string message;
};

// Name of an Embree error code ("RTC_ERROR_INVALID_OPERATION"), for messages.
std::string_view ErrorCodeName(RTCError code);

class EmbreeDevice {
 public:
  // Creates the device with Embree's configuration string (for example "threads=2";
  // empty takes Embree's defaults) and registers the error callback. Throws
  // std::runtime_error naming the code when Embree cannot create the device (for
  // example an unsupported CPU or a malformed configuration).
  explicit EmbreeDevice(const std::string& config = "");
  ~EmbreeDevice();
  EmbreeDevice(const EmbreeDevice&) = delete;
  EmbreeDevice& operator=(const EmbreeDevice&) = delete;

  // The Embree handle, for building scenes; valid while this object lives.
  RTCDevice handle() const { return device_; }

  // The last error the callback recorded (code RTC_ERROR_NONE if none since the last
  // TakeError), and clears it. Thread-safe.
  DeviceError TakeError() const;
  // Errors recorded since creation, taken or not. Thread-safe.
  int error_count() const;

  // Throws std::runtime_error "Embree <code> in <operation>: <message>" when an error
  // was recorded since the last TakeError (and clears it); otherwise does nothing.
  void ThrowIfError(std::string_view operation) const;

 private:
  static void OnError(void* user, RTCError code, const char* message);

  RTCDevice device_ = nullptr;
  mutable std::mutex mutex_;
  mutable DeviceError last_error_;
  int error_count_ = 0;
};

}  // namespace hapticd::embree
