#pragma once

// Non-finite inputs shared by the geometry tests: every copy of a value that has one
// scalar field (a coordinate, a rotation entry, a radius) replaced by NaN, +inf or -inf.

#include <array>
#include <limits>
#include <vector>

#include "server/geometry/types.h"

namespace hapticd::geometry {

// The scalar fields of each input type, in a fixed order.
inline std::vector<double*> ScalarFields(Vector3& v) { return {&v[0], &v[1], &v[2]}; }

inline std::vector<double*> ScalarFields(Sphere& s) {
  std::vector<double*> fields = ScalarFields(s.center);
  fields.push_back(&s.radius);
  return fields;
}

inline std::vector<double*> ScalarFields(Box& b) {
  std::vector<double*> fields = ScalarFields(b.center);
  for (int i = 0; i < 9; ++i) fields.push_back(b.rotation.data() + i);
  for (double* f : ScalarFields(b.half_extents)) fields.push_back(f);
  return fields;
}

inline std::vector<double*> ScalarFields(Capsule& c) {
  std::vector<double*> fields = ScalarFields(c.p0);
  for (double* f : ScalarFields(c.p1)) fields.push_back(f);
  fields.push_back(&c.radius);
  return fields;
}

inline std::vector<double*> ScalarFields(Triangle& t) {
  std::vector<double*> fields = ScalarFields(t.v0);
  for (Vector3* v : {&t.v1, &t.v2}) {
    for (double* f : ScalarFields(*v)) fields.push_back(f);
  }
  return fields;
}

// Several points (a segment pair's four ends, a query point beside a triangle).
template <std::size_t N>
std::vector<double*> ScalarFields(std::array<Vector3, N>& points) {
  std::vector<double*> fields;
  for (Vector3& v : points) {
    for (double* f : ScalarFields(v)) fields.push_back(f);
  }
  return fields;
}

// 3 copies of value per scalar field (NaN, +inf, -inf in that field, the rest as given).
template <typename T>
std::vector<T> WithOneNonFiniteField(const T& value) {
  constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  T probe = value;
  const std::size_t num_fields = ScalarFields(probe).size();
  std::vector<T> variants;
  for (std::size_t i = 0; i < num_fields; ++i) {
    for (const double bad : {kNan, kInf, -kInf}) {
      T variant = value;
      *ScalarFields(variant)[i] = bad;
      variants.push_back(variant);
    }
  }
  return variants;
}

}  // namespace hapticd::geometry
