#include "server/sim/json_fields.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>

namespace hapticd::sim {
namespace {

// Columns orthonormal within this in each entry of R^T R - I (the scene builder's bound).
constexpr double kRotationTolerance = 1e-6;

[[noreturn]] void ThrowWrongType(const JsonAt& at, std::string_view wanted) {
  throw ScenarioError(fmt::format("{} is {}; it must be {}", at.path, JsonTypeName(at.value), wanted));
}

// "the scenario" for the root, else the path.
std::string Describe(std::string_view path) {
  return path.empty() ? std::string("the scenario") : std::string(path);
}

}  // namespace

std::string_view JsonTypeName(const rapidjson::Value& value) {
  switch (value.GetType()) {
    case rapidjson::kNullType: return "null";
    case rapidjson::kFalseType:
    case rapidjson::kTrueType: return "a boolean";
    case rapidjson::kObjectType: return "an object";
    case rapidjson::kArrayType: return "an array";
    case rapidjson::kStringType: return "a string";
    case rapidjson::kNumberType: return "a number";
  }
  return "an unknown JSON value";
}

std::string MemberPath(std::string_view path, std::string_view name) {
  return path.empty() ? std::string(name) : fmt::format("{}.{}", path, name);
}

JsonObject::JsonObject(const JsonAt& at, std::initializer_list<std::string_view> known)
    : value_(at.value), path_(at.path) {
  if (!value_.IsObject()) {
    throw ScenarioError(fmt::format("{} is {}; it must be an object", Describe(path_), JsonTypeName(value_)));
  }
  // the first member not among known
  for (const auto& member : value_.GetObject()) {
    const std::string_view name(member.name.GetString(), member.name.GetStringLength());
    bool is_known = false;
    for (std::string_view k : known) is_known = is_known || k == name;
    if (!is_known) {
      throw ScenarioError(fmt::format("{} is not a known field; {} has: {}", MemberPath(path_, name),
                                      Describe(path_), fmt::join(known, ", ")));
    }
  }
}

bool JsonObject::Has(std::string_view name) const { return Optional(name).has_value(); }

JsonAt JsonObject::Required(std::string_view name) const {
  std::optional<JsonAt> member = Optional(name);
  if (!member) throw ScenarioError(fmt::format("{} is missing; it is required", MemberPath(path_, name)));
  return *member;
}

std::optional<JsonAt> JsonObject::Optional(std::string_view name) const {
  // by length: name need not end in '\0'
  const rapidjson::Value key(
      rapidjson::StringRef(name.data(), static_cast<rapidjson::SizeType>(name.size())));
  const auto member = value_.FindMember(key);
  if (member == value_.MemberEnd()) return std::nullopt;
  return JsonAt{member->value, MemberPath(path_, name)};
}

double ReadNumber(const JsonAt& at) {
  if (!at.value.IsNumber()) ThrowWrongType(at, "a number");
  const double x = at.value.GetDouble();
  // RapidJSON parses neither NaN nor infinity, but a huge integer may overflow
  if (!std::isfinite(x)) throw ScenarioError(fmt::format("{} is {}; it must be a finite number", at.path, x));
  return x;
}

double ReadPositive(const JsonAt& at) {
  const double x = ReadNumber(at);
  if (!(x > 0)) throw ScenarioError(fmt::format("{} is {}; it must be > 0", at.path, x));
  return x;
}

double ReadNonNegative(const JsonAt& at) {
  const double x = ReadNumber(at);
  if (!(x >= 0)) throw ScenarioError(fmt::format("{} is {}; it must be >= 0", at.path, x));
  return x;
}

double ReadInRange(const JsonAt& at, double lo, double hi) {
  const double x = ReadNumber(at);
  if (!(x >= lo && x <= hi)) {
    throw ScenarioError(fmt::format("{} is {}; it must be in [{}, {}]", at.path, x, lo, hi));
  }
  return x;
}

uint64_t ReadUnsigned(const JsonAt& at) {
  if (!at.value.IsNumber()) ThrowWrongType(at, "a non-negative integer");
  if (!at.value.IsUint64()) {
    throw ScenarioError(
        fmt::format("{} is {}; it must be an integer in [0, 2^64)", at.path, at.value.GetDouble()));
  }
  return at.value.GetUint64();
}

bool ReadBool(const JsonAt& at) {
  if (!at.value.IsBool()) ThrowWrongType(at, "a boolean (true or false)");
  return at.value.GetBool();
}

std::string ReadString(const JsonAt& at) {
  if (!at.value.IsString()) ThrowWrongType(at, "a string");
  return std::string(at.value.GetString(), at.value.GetStringLength());
}

int ReadChoice(const JsonAt& at, std::span<const std::string_view> choices) {
  if (!at.value.IsString()) {
    ThrowWrongType(at, fmt::format("one of the strings {}", fmt::join(choices, ", ")));
  }
  const std::string value = ReadString(at);
  for (size_t i = 0; i < choices.size(); ++i) {
    if (choices[i] == value) return static_cast<int>(i);
  }
  throw ScenarioError(
      fmt::format("{} is \"{}\"; it must be one of {}", at.path, value, fmt::join(choices, ", ")));
}

int ReadArraySize(const JsonAt& at) {
  if (!at.value.IsArray()) ThrowWrongType(at, "an array");
  return static_cast<int>(at.value.Size());
}

JsonAt Element(const JsonAt& at, int i) { return {at.value[i], fmt::format("{}[{}]", at.path, i)}; }

geometry::Vector3 ReadVector3(const JsonAt& at) {
  if (!at.value.IsArray()) ThrowWrongType(at, "an array of 3 numbers [x, y, z]");
  if (at.value.Size() != 3) {
    throw ScenarioError(fmt::format("{} has {} elements; it must be [x, y, z]", at.path, at.value.Size()));
  }
  return {ReadNumber(Element(at, 0)), ReadNumber(Element(at, 1)), ReadNumber(Element(at, 2))};
}

geometry::Matrix3 ReadRotation(const JsonAt& at) {
  if (!at.value.IsArray()) ThrowWrongType(at, "an array of 3 rows of 3 numbers");
  if (at.value.Size() != 3) {
    throw ScenarioError(fmt::format("{} has {} rows; it must have 3", at.path, at.value.Size()));
  }
  geometry::Matrix3 r;
  for (int row = 0; row < 3; ++row) r.row(row) = ReadVector3(Element(at, row)).transpose();
  // orthonormal columns
  const double error = (r.transpose() * r - geometry::Matrix3::Identity()).cwiseAbs().maxCoeff();
  if (!(error <= kRotationTolerance)) {
    throw ScenarioError(fmt::format(
        "{} is not a rotation: its columns are off orthonormal by {} (more than {})", at.path, error,
        kRotationTolerance));
  }
  // right-handed: a reflection has determinant -1
  if (r.determinant() < 0) {
    throw ScenarioError(fmt::format("{} is not a rotation: it is a reflection (determinant {})", at.path,
                                    r.determinant()));
  }
  return r;
}

}  // namespace hapticd::sim
