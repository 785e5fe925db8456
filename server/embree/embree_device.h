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
#include <vector>

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

  // The packet widths (4, 8, 16) this device traces natively on this CPU, narrowest
  // first; the wider ones are emulated. They follow the kernels Embree picked.
  std::vector<int> native_packet_widths() const;

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

// What Embree runs on this CPU, for logs, so that a change of CPU shows: its version,
// the kernel ISA it picks for a device made with `config` (for example "AVX512", or
// "AVX2" under "max_isa=avx2"), the ISAs it has kernels for, and the native packet widths.
struct EmbreeIsaReport {
  std::string version;
  std::string kernels;
  std::vector<std::string> compiled;
  std::vector<int> native_packet_widths;
};

// Embree names its choice only in its verbose start-up report on std::cout; this makes a
// device with "verbose=1" while std::cout is redirected, and reads the report. Not
// thread-safe (it swaps std::cout's buffer): call it at start-up. Throws
// std::runtime_error, as EmbreeDevice does, when the device cannot be made.
EmbreeIsaReport ReportEmbreeIsa(const std::string& config = "");

}  // namespace hapticd::embree
