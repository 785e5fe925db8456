#pragma once

// Reading a scenario's JSON values with their paths, so that every error names the
// field: "device.mass is a string; it must be a number", "hand.path[2][0] is 0.5; it
// must be > 1 (the time before it)". All readers throw ScenarioError.

#include <rapidjson/document.h>

#include <initializer_list>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "server/geometry/types.h"
#include "server/sim/scenario.h"

namespace hapticd::sim {

// A JSON value and its path from the scenario's root ("" for the root itself).
struct JsonAt {
  const rapidjson::Value& value;
  std::string path;
};

// "a number", "a string", "an array", "an object", "a boolean", "null".
std::string_view JsonTypeName(const rapidjson::Value& value);

// path joined with a member name ("device" + "mass" -> "device.mass").
std::string MemberPath(std::string_view path, std::string_view name);

// An object whose members must all be among known (else "device.maxforce is not a known
// field; device has: mode, mass, ..."). Members are looked up by exact name.
class JsonObject {
 public:
  JsonObject(const JsonAt& at, std::initializer_list<std::string_view> known);

  const std::string& path() const { return path_; }
  bool Has(std::string_view name) const;
  // The member name; throws "device.mass is missing" when absent.
  JsonAt Required(std::string_view name) const;
  // The member name, or nullopt when absent.
  std::optional<JsonAt> Optional(std::string_view name) const;

 private:
  const rapidjson::Value& value_;
  std::string path_;
};

// A finite number.
double ReadNumber(const JsonAt& at);
// A number > 0.
double ReadPositive(const JsonAt& at);
// A number >= 0.
double ReadNonNegative(const JsonAt& at);
// A number in [lo, hi].
double ReadInRange(const JsonAt& at, double lo, double hi);
// An integer in [0, 2^64).
uint64_t ReadUnsigned(const JsonAt& at);
bool ReadBool(const JsonAt& at);
std::string ReadString(const JsonAt& at);
// One of choices, returned as its index; else "avatar.type is \"cube\"; it must be one
// of point, sphere".
int ReadChoice(const JsonAt& at, std::span<const std::string_view> choices);
// An array (of any length); returns its size.
int ReadArraySize(const JsonAt& at);
// Element i of an array (i < its size).
JsonAt Element(const JsonAt& at, int i);
// [x, y, z] of finite numbers.
geometry::Vector3 ReadVector3(const JsonAt& at);
// A 3x3 row-major rotation matrix: columns orthonormal within 1e-6, determinant +1.
geometry::Matrix3 ReadRotation(const JsonAt& at);

}  // namespace hapticd::sim
