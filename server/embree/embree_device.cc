#include "server/embree/embree_device.h"

#include <algorithm>
#include <iostream>
#include <memory>
#include <sstream>
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

std::vector<int> EmbreeDevice::native_packet_widths() const {
  std::vector<int> widths;
  const std::pair<int, RTCDeviceProperty> properties[] = {
      {4, RTC_DEVICE_PROPERTY_NATIVE_RAY4_SUPPORTED},
      {8, RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED},
      {16, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED}};
  for (const auto& [width, property] : properties) {
    if (rtcGetDeviceProperty(device_, property) != 0) widths.push_back(width);
  }
  return widths;
}

namespace {

// The words of a report line "  Targets : SSE SSE2 ... AVX512  (supported)" after its
// colon, up to the parenthesis.
std::vector<std::string> WordsAfterColon(const std::string& line) {
  std::istringstream words(line.substr(line.find(':') + 1, line.find('(') - line.find(':') - 1));
  std::vector<std::string> out;
  for (std::string word; words >> word;) out.push_back(word);
  return out;
}

}  // namespace

EmbreeIsaReport ReportEmbreeIsa(const std::string& config) {
  std::ostringstream captured;
  std::streambuf* const saved = std::cout.rdbuf(captured.rdbuf());
  std::unique_ptr<EmbreeDevice> device;
  try {
    device = std::make_unique<EmbreeDevice>(config.empty() ? "verbose=1" : config + ",verbose=1");
  } catch (...) {
    std::cout.rdbuf(saved);
    throw;
  }
  std::cout.rdbuf(saved);

  // The report's Config section lists the targets this CPU (under the config) supports,
  // then those compiled in; Embree runs the widest target in both.
  EmbreeIsaReport report;
  report.version = std::to_string(rtcGetDeviceProperty(device->handle(), RTC_DEVICE_PROPERTY_VERSION_MAJOR)) +
                   "." + std::to_string(rtcGetDeviceProperty(device->handle(), RTC_DEVICE_PROPERTY_VERSION_MINOR)) +
                   "." + std::to_string(rtcGetDeviceProperty(device->handle(), RTC_DEVICE_PROPERTY_VERSION_PATCH));
  report.native_packet_widths = device->native_packet_widths();
  std::vector<std::string> supported;
  std::istringstream lines(captured.str());
  for (std::string line; std::getline(lines, line);) {
    if (line.find("(supported)") != std::string::npos) supported = WordsAfterColon(line);
    if (line.find("(compile time enabled)") != std::string::npos) {
      std::istringstream words(line.substr(0, line.find('(')));
      for (std::string word; words >> word;) report.compiled.push_back(word);
    }
  }
  for (const std::string& target : report.compiled) {
    if (std::find(supported.begin(), supported.end(), target) != supported.end()) report.kernels = target;
  }
  // a report Embree changed the shape of: say so rather than guess
  if (report.kernels.empty()) report.kernels = "unknown (Embree's report did not name it)";
  return report;
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
