#pragma once

// A box's corners and surface triangles, for the oracles of the box tests.

#include <array>

#include "server/geometry/types.h"

namespace hapticd::geometry {

// Corner k of a box: bit i of k picks the sign along axis i.
inline Vector3 Corner(const Box& box, int k) {
  Vector3 local;
  for (int i = 0; i < 3; ++i) local[i] = ((k >> i) & 1 ? 1 : -1) * box.half_extents[i];
  return box.center + box.rotation * local;
}

// The 6 faces as 2 triangles each.
inline std::array<Triangle, 12> FaceTriangles(const Box& box) {
  std::array<Triangle, 12> triangles;
  int n = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const int a = 1 << ((axis + 1) % 3);
    const int b = 1 << ((axis + 2) % 3);
    for (int side : {0, 1 << axis}) {
      triangles[n++] = {Corner(box, side), Corner(box, side | a), Corner(box, side | a | b)};
      triangles[n++] = {Corner(box, side), Corner(box, side | a | b), Corner(box, side | b)};
    }
  }
  return triangles;
}

}  // namespace hapticd::geometry
