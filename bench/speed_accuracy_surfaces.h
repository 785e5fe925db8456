#pragma once

// The two curved surfaces of the speed-accuracy chart, with analytic ground truth: a
// sphere of radius R and a torus (ring radius R, tube radius r) around the z axis, both
// centred at the origin. Each gives its exact closest point, outward normal and signed
// distance, the first point where a segment enters it, its tessellations at the
// chart's five levels, and the fixed-seed query inputs every implementation answers.
//
// All lengths in m. Closest points are exact (closed forms); first hits are found by
// bisection on the exact signed distance, to the rounding of the coordinates.

#include <random>
#include <string>
#include <vector>

#include "server/geometry/triangle_mesh.h"
#include "server/geometry/types.h"

namespace hapticd::bench {

using geometry::Vector3;

enum class SurfaceKind { kSphere, kTorus };

struct AnalyticSurface {
  SurfaceKind kind = SurfaceKind::kSphere;
  double radius = 0.05;        // sphere radius, or the torus's ring radius R
  double tube_radius = 0.02;   // torus only: r < R

  std::string name() const { return kind == SurfaceKind::kSphere ? "sphere" : "torus"; }

  // Nearest point of the surface to p. Precondition: p is off the sphere's centre, or
  // off the torus's ring circle and axis (the closest point is then unique).
  Vector3 ClosestPoint(const Vector3& p) const;
  // < 0 inside the solid.
  double SignedDistance(const Vector3& p) const;
  // Unit outward normal at (or, off the surface, through) the closest point to p.
  Vector3 Normal(const Vector3& p) const;
  // Parameter t in [0, 1] of the first point of p -> q on the closed solid's surface
  // (from outside to inside or onto it), or -1 when the segment stays outside. Found on
  // a grid of 256 steps, then by bisection: a segment that enters and leaves within one
  // step (grazing) may be missed.
  double FirstHit(const Vector3& p, const Vector3& q) const;
  // A point on the surface, area-uniform, from rng.
  Vector3 SamplePoint(std::mt19937_64& rng) const;
};

// The chart's five tessellations: 80, 1,280, 20,480, 327,680 and 1,310,720 triangles
// (icospheres of frequency 2, 8, 32, 128, 256; tori of 10x4 .. 1280x512 quads split in
// two). Vertices lie on the surface.
constexpr int kNumLevels = 5;
geometry::TriangleMesh MakeTessellation(const AnalyticSurface& surface, int level);

// Query inputs near the surface and their ground truth.
struct QueryInputs {
  // Closest point: surface points moved along the normal by up to +-point_offset.
  std::vector<Vector3> points;
  std::vector<Vector3> true_closest;
  // First hit: segments p -> q through a surface point, p outside, q inside, at most
  // segment_max_angle from the inward normal.
  std::vector<Vector3> segment_p;
  std::vector<Vector3> segment_q;
  std::vector<Vector3> true_hit;
  // Forces: avatars pressed press_min .. press_max into the surface at these points.
  std::vector<Vector3> site_point;
  std::vector<Vector3> site_normal;
  std::vector<double> site_depth;
};

struct InputOptions {
  int num_points = 2000;
  int num_segments = 2000;
  int num_sites = 64;
  double point_offset = 0.003;
  double segment_outside = 0.004;  // |p - surface point|
  // |q - surface point|: deep enough that every tessellation is crossed (the coarsest
  // torus lies up to 8 mm inside the analytic surface)
  double segment_inside = 0.012;
  double segment_max_angle = 1.0472;  // 60 degrees
  double press_min = 0.001;
  double press_max = 0.002;
};

// Draws the inputs from rng (the same seed gives the same inputs) and computes their
// ground truth. Throws std::runtime_error when a segment's truth is not found (it
// would mean the options are outside the surfaces' curvature).
QueryInputs MakeQueryInputs(const AnalyticSurface& surface, const InputOptions& options,
                            std::mt19937_64& rng);

}  // namespace hapticd::bench
