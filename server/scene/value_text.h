#pragma once

// How the scene's error messages and reasons spell numbers (internal to server/scene).

#include <charconv>
#include <cstdio>
#include <string>

#include "server/scene/pose.h"

namespace hapticd::scene {

// Shortest text that reads back as x ("nan", "inf" and "-inf" included): for values a
// client gave, so the message shows exactly what was sent.
inline std::string FormatExact(double x) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), x);
  return std::string(buffer, result.ptr);
}

// "[x, y, z]" with FormatExact coordinates.
inline std::string FormatExact(const Vector3& v) {
  std::string text = "[";
  for (int k = 0; k < 3; ++k) text.append(FormatExact(v[k])).append(k < 2 ? ", " : "]");
  return text;
}

// Three significant digits, exponent form ("3.1e-05"): for computed values.
inline std::string FormatShort(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.3g", x);
  return buffer;
}

}  // namespace hapticd::scene
