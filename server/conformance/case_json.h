#pragma once

// Reading a conformance case's arguments from JSON and writing its answer. Every
// reader validates what it reads and throws CaseError with the path of the bad value
// ("args.tri[1][2] is NaN"), so each op's code reads as the geometry it runs.

#include <rapidjson/document.h>
#include <rapidjson/stringbuffer.h>
#include <rapidjson/writer.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "server/geometry/types.h"

namespace hapticd::conformance {

using geometry::Triangle;
using geometry::Vector3;

// A case that cannot be answered: bad JSON, a missing or invalid argument.
class CaseError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A JSON value together with its path from the case root, for error messages.
struct JsonAt {
  const rapidjson::Value& value;
  std::string path;

  // The member `name` of this object; throws when this is not an object or lacks it.
  JsonAt operator[](const char* name) const;
  // The array element i; throws when this is not an array or is too short.
  JsonAt operator[](int i) const;
  // The array's length; throws when this is not an array.
  int size() const;
};

// A finite number.
double ReadNumber(const JsonAt& at);
// A number >= 0.
double ReadNonNegative(const JsonAt& at);
// [x, y, z] of finite numbers.
Vector3 ReadVector3(const JsonAt& at);
// [x, y, z], not all zero.
Vector3 ReadDirection(const JsonAt& at);
// A list of [x, y, z]; may be empty.
std::vector<Vector3> ReadPoints(const JsonAt& at);
// [[x,y,z],[x,y,z],[x,y,z]] with non-zero area (exact test).
Triangle ReadTriangle(const JsonAt& at);
// A 3x3 row-major matrix whose columns are orthonormal.
geometry::Matrix3 ReadRotation(const JsonAt& at);

// Writes the members of one answer's "result" object.
class ResultWriter {
 public:
  explicit ResultWriter(rapidjson::Writer<rapidjson::StringBuffer>& writer) : writer_(writer) {}
  void Bool(const char* key, bool value);
  void Int(const char* key, int value);
  // Non-finite numbers cannot be written as JSON; they throw CaseError.
  void Number(const char* key, double value);
  void Vector(const char* key, const Vector3& value);

 private:
  rapidjson::Writer<rapidjson::StringBuffer>& writer_;
};

}  // namespace hapticd::conformance
