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

// Squared distance from p to the closed box: 0 inside or on it, a lower bound of the
// distance to anything it holds. Infinite extents work (an unbounded side is never
// nearer than the others), Aabb::Empty() is infinitely far, and a NaN anywhere (or p
// infinite) gives an unspecified value: callers check finiteness first.
inline double CalcPointAabbDistanceSquared(const Vector3& p, const Aabb& box) {
  return (box.min - p).cwiseMax(p - box.max).cwiseMax(0.0).squaredNorm();
}

// Squared distance between two closed boxes: 0 where they share a point, otherwise the
// squared length of the per-axis gaps. Infinite extents work as above; Aabb::Empty() is
// infinitely far from every box; a NaN gives an unspecified value.
inline double CalcAabbAabbDistanceSquared(const Aabb& x, const Aabb& y) {
  return (x.min - y.max).cwiseMax(y.min - x.max).cwiseMax(0.0).squaredNorm();
}

}  // namespace hapticd::geometry
