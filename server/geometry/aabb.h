#pragma once

// Axis-aligned bounding box. Closed set: boxes that share a face, an edge or a corner
// overlap. A box with min > max on any axis is empty and overlaps nothing.

#include <limits>

#include "server/geometry/types.h"

namespace hapticd::geometry {

struct Aabb {
  Vector3 min = Vector3::Constant(std::numeric_limits<double>::infinity());
  Vector3 max = Vector3::Constant(-std::numeric_limits<double>::infinity());

  static Aabb Empty() { return Aabb{}; }
  static Aabb OfTriangle(const Triangle& t) {
    return {t.v0.cwiseMin(t.v1).cwiseMin(t.v2), t.v0.cwiseMax(t.v1).cwiseMax(t.v2)};
  }

  bool empty() const { return (min.array() > max.array()).any(); }
  Vector3 center() const { return 0.5 * (min + max); }
  Vector3 size() const { return max - min; }
  // Surface area, the cost measure of the SAH; zero for an empty box.
  double surface_area() const {
    if (empty()) return 0;
    const Vector3 d = size();
    return 2 * (d.x() * d.y() + d.y() * d.z() + d.z() * d.x());
  }

  void Extend(const Vector3& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
  void Extend(const Aabb& b) {
    min = min.cwiseMin(b.min);
    max = max.cwiseMax(b.max);
  }
  // Grows the box by margin >= 0 on every side.
  Aabb Inflated(double margin) const {
    return {min.array() - margin, max.array() + margin};
  }
  bool Contains(const Vector3& p) const {
    return (p.array() >= min.array()).all() && (p.array() <= max.array()).all();
  }
  bool Contains(const Aabb& b) const {
    return (b.min.array() >= min.array()).all() && (b.max.array() <= max.array()).all();
  }
};

// True when the closed boxes share at least one point. Exact (comparisons only); a box
// that is empty on any axis, or has a NaN coordinate, overlaps nothing.
inline bool AabbsOverlap(const Aabb& a, const Aabb& b) {
  return (a.min.array() <= b.max.array()).all() && (b.min.array() <= a.max.array()).all() &&
         (a.min.array() <= a.max.array()).all() && (b.min.array() <= b.max.array()).all();
}

}  // namespace hapticd::geometry
