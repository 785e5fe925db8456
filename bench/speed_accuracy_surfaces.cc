#include "bench/speed_accuracy_surfaces.h"

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "server/geometry/mesh_generators.h"

namespace hapticd::bench {
namespace {

// The torus's ring point nearest p: R times p's unit direction in the xy plane.
Vector3 RingPoint(const AnalyticSurface& torus, const Vector3& p) {
  const double rho = std::hypot(p.x(), p.y());
  return torus.radius * Vector3(p.x() / rho, p.y() / rho, 0);
}

// A unit vector within max_angle of axis, uniform over that spherical cap.
Vector3 SampleCapDirection(const Vector3& axis, double max_angle, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> uniform(0, 1);
  const double cos_angle = 1 - uniform(rng) * (1 - std::cos(max_angle));
  const double sin_angle = std::sqrt(std::max(0.0, 1 - cos_angle * cos_angle));
  const double azimuth = 2 * std::numbers::pi * uniform(rng);
  const Vector3 helper = std::abs(axis.x()) < 0.9 ? Vector3::UnitX() : Vector3::UnitY();
  const Vector3 e1 = axis.cross(helper).normalized();
  const Vector3 e2 = axis.cross(e1);
  return cos_angle * axis + sin_angle * (std::cos(azimuth) * e1 + std::sin(azimuth) * e2);
}

}  // namespace

Vector3 AnalyticSurface::ClosestPoint(const Vector3& p) const {
  if (kind == SurfaceKind::kSphere) return radius * p.normalized();
  const Vector3 ring = RingPoint(*this, p);
  return ring + tube_radius * (p - ring).normalized();
}

double AnalyticSurface::SignedDistance(const Vector3& p) const {
  if (kind == SurfaceKind::kSphere) return p.norm() - radius;
  return (p - RingPoint(*this, p)).norm() - tube_radius;
}

Vector3 AnalyticSurface::Normal(const Vector3& p) const {
  if (kind == SurfaceKind::kSphere) return p.normalized();
  return (p - RingPoint(*this, p)).normalized();
}

double AnalyticSurface::FirstHit(const Vector3& p, const Vector3& q) const {
  constexpr int kSteps = 256;
  auto distance_at = [&](double t) { return SignedDistance(p + t * (q - p)); };
  if (distance_at(0) <= 0) return 0;
  // the first grid step that ends on or inside the surface brackets the entry
  double lo = 0;
  double hi = -1;
  for (int i = 1; i <= kSteps; ++i) {
    const double t = static_cast<double>(i) / kSteps;
    if (distance_at(t) <= 0) {
      hi = t;
      break;
    }
    lo = t;
  }
  if (hi < 0) return -1;
  // bisection until the bracket stops shrinking (1 ulp of t)
  while (true) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    (distance_at(mid) <= 0 ? hi : lo) = mid;
  }
  return hi;
}

Vector3 AnalyticSurface::SamplePoint(std::mt19937_64& rng) const {
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> uniform(0, 1);
  if (kind == SurfaceKind::kSphere) {
    return radius * Vector3(normal(rng), normal(rng), normal(rng)).normalized();
  }
  // the torus's area element is proportional to R + r cos(phi): rejection on phi
  const double theta = 2 * std::numbers::pi * uniform(rng);
  double phi = 0;
  do {
    phi = 2 * std::numbers::pi * uniform(rng);
  } while (uniform(rng) * (radius + tube_radius) > radius + tube_radius * std::cos(phi));
  const double rho = radius + tube_radius * std::cos(phi);
  return Vector3(rho * std::cos(theta), rho * std::sin(theta), tube_radius * std::sin(phi));
}

geometry::TriangleMesh MakeTessellation(const AnalyticSurface& surface, int level) {
  if (level < 0 || level >= kNumLevels) {
    throw std::invalid_argument("tessellation level " + std::to_string(level) + " is not in 0..4");
  }
  // 20 f^2 triangles for the icosphere, 2 M m for the torus: the same counts
  constexpr int kFrequency[kNumLevels] = {2, 8, 32, 128, 256};
  constexpr int kTubeSegments[kNumLevels] = {4, 16, 64, 256, 512};
  if (surface.kind == SurfaceKind::kSphere) {
    return geometry::MakeIcosphere(kFrequency[level], surface.radius);
  }
  const int minor = kTubeSegments[level];
  return geometry::MakeTorus(surface.radius, surface.tube_radius, minor * 5 / 2, minor);
}

QueryInputs MakeQueryInputs(const AnalyticSurface& surface, const InputOptions& options,
                            std::mt19937_64& rng) {
  QueryInputs in;
  std::uniform_real_distribution<double> unit(-1, 1);
  // closest point: on both sides of the surface
  for (int i = 0; i < options.num_points; ++i) {
    const Vector3 x = surface.SamplePoint(rng);
    const Vector3 p = x + options.point_offset * unit(rng) * surface.Normal(x);
    in.points.push_back(p);
    in.true_closest.push_back(surface.ClosestPoint(p));
  }
  // first hit: from outside, through a surface point, to inside
  for (int i = 0; i < options.num_segments; ++i) {
    const Vector3 x = surface.SamplePoint(rng);
    const Vector3 u = SampleCapDirection(-surface.Normal(x), options.segment_max_angle, rng);
    const Vector3 p = x - options.segment_outside * u;
    const Vector3 q = x + options.segment_inside * u;
    const double t = surface.FirstHit(p, q);
    if (t < 0) throw std::runtime_error("a chart segment misses the analytic " + surface.name());
    in.segment_p.push_back(p);
    in.segment_q.push_back(q);
    in.true_hit.push_back(p + t * (q - p));
  }
  // forces: pressed between press_min and press_max deep
  std::uniform_real_distribution<double> depth(options.press_min, options.press_max);
  for (int i = 0; i < options.num_sites; ++i) {
    const Vector3 x = surface.SamplePoint(rng);
    in.site_point.push_back(x);
    in.site_normal.push_back(surface.Normal(x));
    in.site_depth.push_back(depth(rng));
  }
  return in;
}

}  // namespace hapticd::bench
