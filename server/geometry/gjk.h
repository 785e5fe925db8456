#pragma once

// GJK distance (Gilbert, Johnson & Keerthi 1988) between two convex shapes given by
// support mappings, with the signed-volumes sub-simplex solver of Montanari, Petrinic
// & Barbieri 2017 ("Improving the GJK algorithm for faster and more reliable distance
// queries between convex objects"). Works on the Minkowski difference B - A: its point
// nearest the origin is point_b - point_a.
//
// Shapes: point sets (brute force), convex hulls (hill climbing over the vertex
// adjacency, optionally posed), and spheres, boxes and capsules for later pairs. A
// support map may report vertex indices; GJK then records its final simplex as vertex
// pairs, which a later query can start from (temporal coherence, feature_tracker.h).

#include <array>
#include <span>

#include "server/geometry/convex_hull.h"
#include "server/geometry/types.h"

namespace hapticd::geometry {

// A point of a shape farthest along a direction; vertex is its index for shapes with
// vertices (point sets, hulls, box corners), -1 otherwise.
struct SupportPoint {
  Vector3 point = Vector3::Zero();
  int vertex = -1;
};

// A convex shape seen through its support mapping, in the caller's frame.
class SupportMap {
 public:
  virtual ~SupportMap() = default;
  // A point maximizing dir . x over the shape (any of them on ties; any point of the
  // shape when dir is zero). hint: a vertex to start a local search from (-1: none).
  // Adds the number of vertices examined to *visits when visits is not null.
  virtual SupportPoint Support(const Vector3& dir, int hint, int* visits) const = 0;
  // The vertex with index vertex (as Support reported it); false for shapes without
  // vertices or an index out of range.
  virtual bool GetVertex(int vertex, Vector3* point) const {
    (void)vertex, (void)point;
    return false;
  }
};

// The convex hull of a point set, searched exhaustively. Does not own the points.
class PointSetSupport final : public SupportMap {
 public:
  explicit PointSetSupport(std::span<const Vector3> points) : points_(points) {}
  SupportPoint Support(const Vector3& dir, int hint, int* visits) const override;
  bool GetVertex(int vertex, Vector3* point) const override;

 private:
  std::span<const Vector3> points_;
};

// A hull placed by the pose (R_WH, p_WH): point_W = R_WH point_H + p_WH. Support
// climbs from the hint along hull edges to a vertex no neighbour beats, which on a
// convex hull is a global maximum. Does not own the hull; the hull must be non-empty.
class HullSupport final : public SupportMap {
 public:
  explicit HullSupport(const ConvexHull& hull, const Matrix3& R_WH = Matrix3::Identity(),
                       const Vector3& p_WH = Vector3::Zero())
      : hull_(&hull), R_WH_(R_WH), p_WH_(p_WH) {}
  SupportPoint Support(const Vector3& dir, int hint, int* visits) const override;
  bool GetVertex(int vertex, Vector3* point) const override;
  void set_pose(const Matrix3& R_WH, const Vector3& p_WH) { R_WH_ = R_WH, p_WH_ = p_WH; }

 private:
  const ConvexHull* hull_;
  Matrix3 R_WH_;
  Vector3 p_WH_;
};

// Primitive adapters. radius >= 0 and half_extents >= 0 are preconditions.
class SphereSupport final : public SupportMap {
 public:
  explicit SphereSupport(const Sphere& sphere) : sphere_(sphere) {}
  SupportPoint Support(const Vector3& dir, int hint, int* visits) const override;

 private:
  Sphere sphere_;
};

// Box corners are vertices 0..7: bit k set means +half_extents[k] along axis k.
class BoxSupport final : public SupportMap {
 public:
  explicit BoxSupport(const Box& box) : box_(box) {}
  SupportPoint Support(const Vector3& dir, int hint, int* visits) const override;
  bool GetVertex(int vertex, Vector3* point) const override;

 private:
  Box box_;
};

class CapsuleSupport final : public SupportMap {
 public:
  explicit CapsuleSupport(const Capsule& capsule) : capsule_(capsule) {}
  SupportPoint Support(const Vector3& dir, int hint, int* visits) const override;

 private:
  Capsule capsule_;
};

// The final simplex as (vertex of a, vertex of b) pairs; size 0 when unknown or when
// a shape has no vertices.
struct GjkSimplex {
  int size = 0;
  std::array<int, 4> vertex_a = {-1, -1, -1, -1};
  std::array<int, 4> vertex_b = {-1, -1, -1, -1};
};

struct GjkOptions {
  // Stop when the distance is known to this relative accuracy (the gap between the
  // upper bound |v| and the lower bound v.w/|v|). Polytopes usually stop earlier, when
  // the support point repeats.
  double relative_tolerance = 1e-13;
  int max_iterations = 128;
};

struct GjkResult {
  // True when the shapes touch or overlap: the origin lies in B - A to within
  // rounding (about 1e-14 of the simplex size). distance is then 0.
  bool intersect = false;
  // Euclidean distance between the shapes, >= 0.
  double distance = 0;
  // Unit, from a towards b: point_b - point_a = distance * normal. +x (unspecified)
  // when intersect.
  Vector3 normal = Vector3::UnitX();
  // Witness points, on a and on b (the last simplex's convex combinations).
  Vector3 point_a = Vector3::Zero();
  Vector3 point_b = Vector3::Zero();
  int iterations = 0;
  // Vertices examined by the support searches.
  int support_visits = 0;
  GjkSimplex simplex;
};

// Distance between a and b (both in one frame). warm_start: a simplex from an earlier
// query of the same shapes (vertex pairs are re-evaluated at the shapes' current
// poses), or null for a cold start. Non-finite input gives unspecified values after
// at most max_iterations steps, never a crash. Does not allocate. Charges the thread's
// work meter (work_meter.h) a unit per eight vertices the support searches examine, and
// stops early, with the answer so far, once its budget is spent.
GjkResult CalcGjkDistance(const SupportMap& a, const SupportMap& b,
                          const GjkSimplex* warm_start = nullptr, const GjkOptions& options = {});

}  // namespace hapticd::geometry
