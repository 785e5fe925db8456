#include "server/conformance/case_json.h"

#include <cmath>
#include <fmt/format.h>

#include "server/geometry/exact_predicates.h"

namespace hapticd::conformance {
namespace {

// Orthonormal columns within this, in each entry of R^T R - I; rotations written
// with 16 or more digits are far inside it.
constexpr double kRotationTolerance = 1e-9;

std::string Describe(double x) {
  if (std::isnan(x)) return "NaN";
  if (std::isinf(x)) return x > 0 ? "Infinity" : "-Infinity";
  return fmt::format("{}", x);
}

}  // namespace

JsonAt JsonAt::operator[](const char* name) const {
  if (!value.IsObject()) throw CaseError(path + " must be an object");
  const auto member = value.FindMember(name);
  if (member == value.MemberEnd()) throw CaseError(fmt::format("{}.{} is missing", path, name));
  return {member->value, fmt::format("{}.{}", path, name)};
}

JsonAt JsonAt::operator[](int i) const {
  if (!value.IsArray()) throw CaseError(path + " must be an array");
  if (i >= static_cast<int>(value.Size())) {
    throw CaseError(fmt::format("{} has {} elements; expected more", path, value.Size()));
  }
  return {value[i], fmt::format("{}[{}]", path, i)};
}

int JsonAt::size() const {
  if (!value.IsArray()) throw CaseError(path + " must be an array");
  return static_cast<int>(value.Size());
}

double ReadNumber(const JsonAt& at) {
  if (!at.value.IsNumber()) throw CaseError(at.path + " must be a number");
  const double x = at.value.GetDouble();
  if (!std::isfinite(x)) throw CaseError(fmt::format("{} is {}", at.path, Describe(x)));
  return x;
}

double ReadNonNegative(const JsonAt& at) {
  const double x = ReadNumber(at);
  if (x < 0) throw CaseError(fmt::format("{} = {} is negative", at.path, x));
  return x;
}

Vector3 ReadVector3(const JsonAt& at) {
  if (at.size() != 3) throw CaseError(fmt::format("{} must be [x, y, z]; it has {} elements", at.path, at.size()));
  return {ReadNumber(at[0]), ReadNumber(at[1]), ReadNumber(at[2])};
}

Vector3 ReadDirection(const JsonAt& at) {
  const Vector3 d = ReadVector3(at);
  if (d.isZero(0)) throw CaseError(at.path + " is the zero vector");
  return d;
}

std::vector<Vector3> ReadPoints(const JsonAt& at) {
  std::vector<Vector3> points;
  points.reserve(at.size());
  for (int i = 0; i < at.size(); ++i) points.push_back(ReadVector3(at[i]));
  return points;
}

Triangle ReadTriangle(const JsonAt& at) {
  if (at.size() != 3) throw CaseError(fmt::format("{} must have 3 corners; it has {}", at.path, at.size()));
  const Triangle tri{ReadVector3(at[0]), ReadVector3(at[1]), ReadVector3(at[2])};
  if (geometry::IsDegenerateTriangle(tri.v0, tri.v1, tri.v2)) {
    throw CaseError(at.path + " is degenerate: its corners are collinear or coincide");
  }
  return tri;
}

geometry::Matrix3 ReadRotation(const JsonAt& at) {
  if (at.size() != 3) throw CaseError(fmt::format("{} must have 3 rows; it has {}", at.path, at.size()));
  geometry::Matrix3 r;
  for (int row = 0; row < 3; ++row) r.row(row) = ReadVector3(at[row]).transpose();
  const double error = (r.transpose() * r - geometry::Matrix3::Identity()).cwiseAbs().maxCoeff();
  if (!(error <= kRotationTolerance)) {
    throw CaseError(fmt::format("{} is not a rotation: its columns are off orthonormal by {}", at.path, error));
  }
  return r;
}

void ResultWriter::Bool(const char* key, bool value) {
  writer_.Key(key);
  writer_.Bool(value);
}

void ResultWriter::Int(const char* key, int value) {
  writer_.Key(key);
  writer_.Int(value);
}

void ResultWriter::Number(const char* key, double value) {
  if (!std::isfinite(value)) throw CaseError(fmt::format("result {} is {}", key, Describe(value)));
  writer_.Key(key);
  writer_.Double(value);
}

void ResultWriter::Vector(const char* key, const Vector3& value) {
  for (double x : value) {
    if (!std::isfinite(x)) throw CaseError(fmt::format("result {} has a non-finite coordinate", key));
  }
  writer_.Key(key);
  writer_.StartArray();
  for (double x : value) writer_.Double(x);
  writer_.EndArray();
}

}  // namespace hapticd::conformance
