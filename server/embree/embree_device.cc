#include "server/embree/embree_device.h"

#include <stdexcept>

namespace hapticd::embree {

std::string_view ErrorCodeName(RTCError code) {
  switch (code) {
    case RTC_ERROR_NONE:
      return "RTC_ERROR_NONE";
    case RTC_ERROR_UNKNOWN:
      return "RTC_ERROR_UNKNOWN";
    case RTC_ERROR_INVALID_ARGUMENT:
      return "RTC_ERROR_INVALID_ARGUMENT";
    case RTC_ERROR_INVALID_OPERATION:
      return "RTC_ERROR_INVALID_OPERATION";
    case RTC_ERROR_OUT_OF_MEMORY:
      return "RTC_ERROR_OUT_OF_MEMORY";
    case RTC_ERROR_UNSUPPORTED_CPU:
      return "RTC_ERROR_UNSUPPORTED_CPU";
    case RTC_ERROR_CANCELLED:
      return "RTC_ERROR_CANCELLED";
  }
  return "RTC_ERROR_(unrecognised)";
}

EmbreeDevice::EmbreeDevice(const std::string& config) {
  device_ = rtcNewDevice(config.c_str());
  // no device: Embree keeps the reason in its per-thread error slot, with no message
  if (device_ == nullptr) {
    const RTCError code = rtcGetDeviceError(nullptr);
    throw std::runtime_error("Cannot create an Embree device with config \"" + config +
                             "\": " + std::string(ErrorCodeName(code)));
  }
  rtcSetDeviceErrorFunction(device_, &EmbreeDevice::OnError, this);
}

EmbreeDevice::~EmbreeDevice() {
  // scenes still alive hold their own reference to the device; they must not report
  // errors to this object any more
  rtcSetDeviceErrorFunction(device_, nullptr, nullptr);
  rtcReleaseDevice(device_);
}

void EmbreeDevice::OnError(void* user, RTCError code, const char* message) {
  auto* self = static_cast<EmbreeDevice*>(user);
  const std::lock_guard lock(self->mutex_);
  self->last_error_ = {code, message != nullptr ? message : ""};
  ++self->error_count_;
}

DeviceError EmbreeDevice::TakeError() const {
  const std::lock_guard lock(mutex_);
  DeviceError error = std::move(last_error_);
  last_error_ = {};
  return error;
}

int EmbreeDevice::error_count() const {
  const std::lock_guard lock(mutex_);
  return error_count_;
}

void EmbreeDevice::ThrowIfError(std::string_view operation) const {
  const DeviceError error = TakeError();
  if (error.code == RTC_ERROR_NONE) return;
  throw std::runtime_error("Embree " + std::string(ErrorCodeName(error.code)) + " in " +
                           std::string(operation) + ": " + error.message);
}

}  // namespace hapticd::embree
