#include "server/query/shape_queries.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "server/geometry/closest_point_triangle.h"
#include "server/geometry/point_hull.h"
#include "server/geometry/sphere_box.h"
#include "server/geometry/sphere_convex_sweep.h"
#include "server/geometry/sphere_sphere.h"
#include "server/geometry/work_meter.h"
#include "server/query/mesh_backends.h"

namespace hapticd::query {
namespace {

using geometry::ConvexHull;
using geometry::MeshBvh;
using scene::BoxShape;
using scene::CapsuleShape;
using scene::ConvexShape;
using scene::MeshShape;
using scene::PlaneShape;
using scene::SphereShape;

constexpr double kInfinity = std::numeric_limits<double>::infinity();
// A sphere this close (m) to a mesh beyond its radius rests on it: motion into the
// nearest triangle stops at once (a proxy rests a skin of 1e-9 m off the surface).
constexpr double kRestingGap = 1e-8;

// The unit vector along v, or fallback when v is too short to have a direction.
Vector3 UnitOr(const Vector3& v, const Vector3& fallback) {
  const double length = v.norm();
  return length > 1e-300 ? Vector3(v / length) : fallback;
}

// The primitives' probes are the geometry kernels' answers for a sphere of radius 0 at p
// (their degenerate cases, a point at a sphere's centre or on a capsule's axis, are
// defined in those headers).
ShapeProbe ProbeFromKernel(double distance, const Vector3& point, const Vector3& normal) {
  ShapeProbe probe;
  probe.found = true;
  probe.signed_distance = distance;
  probe.point_B = point;
  probe.normal_B = normal;
  return probe;
}

ShapeProbe ProbeBall(const Vector3& center, double radius, const Vector3& p) {
  const geometry::SphereSphereResult contact = geometry::CollideSpheres({center, radius}, {p, 0});
  return ProbeFromKernel(contact.distance, contact.point_a, contact.normal);
}

ShapeProbe ProbeSphere(const SphereShape& sphere, const Vector3& p) {
  return ProbeBall(Vector3::Zero(), sphere.radius, p);
}

ShapeProbe ProbeBox(const BoxShape& box, const Vector3& p) {
  const geometry::SphereBoxResult contact =
      geometry::CollideSphereBox({p, 0}, {Vector3::Zero(), geometry::Matrix3::Identity(), box.half_extents});
  return ProbeFromKernel(contact.distance, contact.point_box, contact.normal);
}

// The ball of the capsule's radius around the axis point nearest p.
ShapeProbe ProbeCapsule(const CapsuleShape& capsule, const Vector3& p) {
  const Vector3 axis_point(0, 0, std::clamp(p.z(), -capsule.half_length, capsule.half_length));
  return ProbeBall(axis_point, capsule.radius, p);
}

ShapeProbe ProbePlane(const Vector3& p) {
  ShapeProbe probe;
  probe.found = true;
  probe.signed_distance = p.z();
  probe.point_B = Vector3(p.x(), p.y(), 0);
  probe.normal_B = Vector3::UnitZ();
  return probe;
}

ShapeProbe ProbeConvex(const ConvexHull& hull, const Vector3& p) {
  const geometry::PointHullResult nearest = geometry::CalcPointHullDistance(hull, p);
  if (!nearest.found) return {};
  return ProbeFromKernel(nearest.signed_distance, nearest.point, nearest.normal);
}

// A closed mesh: the closest surface point, then the side of p against the closest
// feature's angle-weighted pseudo-normal (Baerentzen & Aanaes 2005). A point deeper
// inside than max_distance is still found, by the inside test. An open mesh is a
// surface: the distance is unsigned, and nothing is inside it.
ShapeProbe ProbeMesh(const MeshShape& shape, const Vector3& p, double max_distance) {
  ShapeProbe probe;
  const geometry::TriangleMesh& mesh = shape.bvh->mesh();
  const bool solid = mesh.is_closed();
  geometry::MeshClosestPoint closest = BackendOf(shape).closest_point(shape, p, max_distance);
  if (!closest.found) {
    if (!solid || !mesh.bounds().Contains(p)) return probe;
    const geometry::MeshSignedDistance inside = BackendOf(shape).signed_distance(shape, p);
    if (!inside.inside) return probe;
    closest = inside.closest;
  }
  const Vector3 pseudo_normal = mesh.FeatureNormal(closest.triangle, closest.feature);
  const Vector3 gap = p - closest.point;
  const bool outside = !solid || gap.dot(pseudo_normal) > 0;
  probe.found = true;
  probe.triangle = closest.triangle;
  probe.point_B = closest.point;
  probe.signed_distance = outside ? closest.distance : -closest.distance;
  // where opposed faces meet their pseudo-normals cancel: the face's own normal then,
  // and some unit normal always (a contact's force needs a direction)
  const Vector3 surface_normal =
      UnitOr(pseudo_normal, UnitOr(mesh.face_normal(closest.triangle), Vector3::UnitZ()));
  // on the surface the gap has no direction: the surface's normal is the outward normal
  probe.normal_B = UnitOr(outside ? gap : Vector3(-gap), surface_normal);
  if (closest.distance < 1e-12 * (1 + p.cwiseAbs().maxCoeff())) probe.normal_B = surface_normal;
  return probe;
}

// The primitives' and hulls' sweeps are the geometry kernels' (sphere_convex_sweep.h,
// where their degenerate answers are defined), in B.
ShapeSweep SweepFromKernel(const geometry::ConvexSweepHit& hit) {
  ShapeSweep sweep;
  sweep.hit = hit.hit;
  sweep.t = hit.t;
  sweep.point_B = hit.point;
  sweep.normal_B = hit.normal;
  return sweep;
}

// A primitive or hull swept by conservative advancement over its probe (a ray cast
// from inside is SweepSolid's).
ShapeSweep SweepConvex(const scene::Shape& shape, const Vector3& a, const Vector3& b, double r) {
  const auto probe_at = [&](const Vector3& p) {
    const ShapeProbe probe = ProbeShape(shape, p, kInfinity);
    return geometry::ConvexProbe{probe.found, probe.signed_distance, probe.point_B, probe.normal_B};
  };
  return SweepFromKernel(geometry::SweepSphereConvex(probe_at, a, b, r));
}

// A sphere resting on a dense mesh (a proxy in contact: every tick starts so) lies
// within the BVH's grown boxes of thousands of triangles, and a sweep pressing into the
// surface visits them all. The nearest triangle, found by a pruned closest-point query,
// bounds the answer: its own first contact t_n is no earlier than the mesh's, so the
// mesh is swept only over [0, t_n], a short sweep that few boxes meet. The result is
// the same first contact as a full sweep, except that a sphere resting within
// kRestingGap of the nearest triangle and moving into it (deeper than the sweep's skin,
// geometry::CalcSphereSweepSkin) stops at t = 0 at once.
//
// With near (the triangles a query::Neighbourhood gathered), each of the two mesh
// questions is asked of them where they decide it (gathered_mesh.h), else of the backend.
ShapeSweep SweepMesh(const MeshShape& shape, const Vector3& a, const Vector3& b, double r,
                     const GatheredMesh* near) {
  const MeshBvh& bvh = *shape.bvh;
  const MeshBackend& backend = BackendOf(shape);
  const auto closest_point = [&](const Vector3& p, double max_distance) {
    if (near != nullptr) {
      if (const auto closest = FindGatheredClosestPoint(*near, p, max_distance)) return *closest;
    }
    return backend.closest_point(shape, p, max_distance);
  };
  const auto sweep_sphere = [&](const Vector3& from, const Vector3& to) {
    if (near != nullptr) {
      if (const auto hit = SweepGatheredSphere(*near, from, to, r)) return *hit;
    }
    return backend.sweep_sphere(shape, from, to, r);
  };
  ShapeSweep sweep;
  Vector3 end = b;
  geometry::SphereSweepHit bound;
  if (r > 0) {
    const geometry::MeshClosestPoint nearest = closest_point(a, r + (b - a).norm());
    if (nearest.found && nearest.distance <= r + kRestingGap) {
      const Vector3 pseudo_normal = bvh.mesh().FeatureNormal(nearest.triangle, nearest.feature);
      const Vector3 normal = UnitOr(a - nearest.point, pseudo_normal);
      // it blocks when the motion would take it a sweep's skin deeper than touching
      const double skin = geometry::CalcSphereSweepSkin(a, b, r);
      if (nearest.distance + (b - a).dot(normal) < r - skin) {
        sweep.hit = true;
        sweep.point_B = nearest.point;
        sweep.normal_B = normal;
        sweep.triangle = nearest.triangle;
        return sweep;
      }
    }
    if (nearest.found) {
      bound = geometry::SweepSphereTriangle(bvh.mesh().triangle(nearest.triangle), a, b, r);
      bound.triangle = nearest.triangle;
      if (bound.hit && bound.t == 0) end = a;
      if (bound.hit && bound.t > 0) end = a + bound.t * (b - a);
    }
  }
  geometry::SphereSweepHit hit;
  if (end != a) {
    hit = sweep_sphere(a, end);
    // back to the parameter of the whole sweep a -> b
    if (hit.hit && bound.hit) hit.t *= bound.t;
  }
  if (!hit.hit) hit = bound;
  sweep.hit = hit.hit;
  sweep.t = hit.t;
  sweep.point_B = hit.point;
  sweep.normal_B = hit.normal;
  sweep.triangle = hit.triangle;
  return sweep;
}

// A point (r = 0) from inside a convex solid (deeper than the touching tolerance, which
// counts as on the surface): where the segment leaves it, found as the first contact of
// the reversed segment from an end that is not inside (the line meets a convex solid in
// one interval), its normal turned back towards a. Otherwise Sweep's first contact.
template <ShapeSweep (*Sweep)(const scene::Shape&, const Vector3&, const Vector3&, double)>
ShapeSweep SweepSolid(const scene::Shape& shape, const Vector3& a, const Vector3& b, double r) {
  if (r == 0 && ProbeShape(shape, a, kInfinity).signed_distance < -geometry::kConvexSweepTolerance) {
    const ShapeProbe end = ProbeShape(shape, b, kInfinity);
    if (!end.found || end.signed_distance < -geometry::kConvexSweepTolerance) return {};
    ShapeSweep exit = Sweep(shape, b, a, 0);
    if (!exit.hit) return {};
    exit.t = 1 - exit.t;
    exit.normal_B = -exit.normal_B;
    return exit;
  }
  return Sweep(shape, a, b, r);
}

// A whole solid is one feature: its nearest point, when within radius.
int FindSolidFeatures(const scene::Shape& shape, const Vector3& p, double radius,
                      std::span<geometry::SphereMeshContact> out) {
  const ShapeProbe probe = ProbeShape(shape, p, radius);
  if (!probe.found || probe.signed_distance > radius) return 0;
  if (!out.empty()) out[0] = {-1, probe.point_B, probe.normal_B, radius - probe.signed_distance, {}};
  return 1;
}

// Each triangle within radius (distances unsigned: a triangle has no inside).
int FindMeshFeatures(const scene::Shape& shape, const Vector3& p, double radius,
                     std::span<geometry::SphereMeshContact> out) {
  const MeshShape& mesh = std::get<MeshShape>(shape);
  return BackendOf(mesh).sphere_contacts(mesh, {p, radius}, out).num_touching;
}

// The questions of this file for one representation. Every query dispatches through
// kRepresentations, so a new representation is one row.
struct RepresentationQueries {
  scene::ShapeType type;
  // the nearest surface point (max_distance: meshes look no farther)
  ShapeProbe (*probe)(const scene::Shape& shape, const Vector3& p, double max_distance);
  ShapeSweep (*sweep)(const scene::Shape& shape, const Vector3& a, const Vector3& b, double r);
  int (*features)(const scene::Shape& shape, const Vector3& p, double radius,
                  std::span<geometry::SphereMeshContact> out);
};

template <class S, ShapeProbe (*Probe)(const S&, const Vector3&)>
ShapeProbe ProbeAs(const scene::Shape& shape, const Vector3& p, double) {
  return Probe(std::get<S>(shape), p);
}

ShapeProbe ProbeAnyPlane(const scene::Shape&, const Vector3& p, double) { return ProbePlane(p); }
ShapeProbe ProbeAnyConvex(const scene::Shape& shape, const Vector3& p, double) {
  return ProbeConvex(*std::get<ConvexShape>(shape).hull, p);
}
ShapeProbe ProbeAnyMesh(const scene::Shape& shape, const Vector3& p, double max_distance) {
  return ProbeMesh(std::get<MeshShape>(shape), p, max_distance);
}
ShapeSweep SweepAnySphere(const scene::Shape& shape, const Vector3& a, const Vector3& b, double r) {
  const geometry::Sphere ball{Vector3::Zero(), std::get<SphereShape>(shape).radius};
  return SweepFromKernel(geometry::SweepSphereSphere(ball, a, b, r));
}
ShapeSweep SweepAnyMesh(const scene::Shape& shape, const Vector3& a, const Vector3& b, double r) {
  return SweepMesh(std::get<MeshShape>(shape), a, b, r, nullptr);
}

// SweepSolid<SweepAnySphere>, with its probe at a (a point sweep starting deep inside
// goes out backwards) asked only where |a| - R < -tolerance: the probe's signed distance
// is |a| - R evaluated alike (or 0 or a denormal where the exact sign disagrees), so
// it can be below -tolerance only there; most sweeps start outside and skip it.
ShapeSweep SweepSolidSphere(const scene::Shape& shape, const Vector3& a, const Vector3& b, double r) {
  const double radius = std::get<SphereShape>(shape).radius;
  if (r == 0 && a.norm() - radius < -geometry::kConvexSweepTolerance) {
    return SweepSolid<SweepAnySphere>(shape, a, b, r);
  }
  return SweepAnySphere(shape, a, b, r);
}

using scene::ShapeType;
constexpr std::array<RepresentationQueries, static_cast<int>(ShapeType::kCount)> kRepresentations = {{
    {ShapeType::kSphere, ProbeAs<SphereShape, ProbeSphere>, SweepSolidSphere, FindSolidFeatures},
    {ShapeType::kBox, ProbeAs<BoxShape, ProbeBox>, SweepSolid<SweepConvex>, FindSolidFeatures},
    {ShapeType::kCapsule, ProbeAs<CapsuleShape, ProbeCapsule>, SweepSolid<SweepConvex>, FindSolidFeatures},
    {ShapeType::kPlane, ProbeAnyPlane, SweepSolid<SweepConvex>, FindSolidFeatures},
    {ShapeType::kConvex, ProbeAnyConvex, SweepSolid<SweepConvex>, FindSolidFeatures},
    {ShapeType::kMesh, ProbeAnyMesh, SweepAnyMesh, FindMeshFeatures},
}};

constexpr bool RowsInTypeOrder() {
  for (int i = 0; i < static_cast<int>(ShapeType::kCount); ++i) {
    if (kRepresentations[i].type != static_cast<ShapeType>(i)) return false;
  }
  return true;
}
static_assert(RowsInTypeOrder(), "one row per scene::ShapeType, in its order");

const RepresentationQueries* RowOf(const scene::Shape& shape) {
  const int type = static_cast<int>(scene::TypeOf(shape));
  return type >= 0 && type < static_cast<int>(ShapeType::kCount) ? &kRepresentations[type] : nullptr;
}

// A sweep with nothing to answer: a non-finite end or radius, a negative radius, no motion.
bool IsEmptySweep(const Vector3& a_B, const Vector3& b_B, double r) {
  return !a_B.allFinite() || !b_B.allFinite() || !(r >= 0) || !std::isfinite(r) || a_B == b_B;
}

}  // namespace

ShapeProbe ProbeShape(const scene::Shape& shape, const Vector3& p_B, double max_distance) {
  const RepresentationQueries* row = RowOf(shape);
  if (row == nullptr || !p_B.allFinite() || std::isnan(max_distance)) return {};
  ShapeProbe probe = row->probe(shape, p_B, max_distance);
  if (probe.signed_distance > max_distance) probe.found = false;
  return probe;
}

ShapeSweep SweepSphereShape(const scene::Shape& shape, const Vector3& a_B, const Vector3& b_B,
                            double r) {
  const RepresentationQueries* row = RowOf(shape);
  if (row == nullptr || IsEmptySweep(a_B, b_B, r)) return {};
  return row->sweep(shape, a_B, b_B, r);
}

ShapeSweep SweepSphereShape(const scene::Shape& shape, const Vector3& a_B, const Vector3& b_B, double r,
                            const GatheredMesh& near) {
  const auto* mesh = std::get_if<MeshShape>(&shape);
  if (mesh == nullptr) return SweepSphereShape(shape, a_B, b_B, r);
  if (IsEmptySweep(a_B, b_B, r)) return {};
  return SweepMesh(*mesh, a_B, b_B, r, &near);
}

void SweepPointsShape(const scene::Shape& shape, std::span<const Vector3> a_B, std::span<const Vector3> b_B,
                      std::span<ShapeSweep> out) {
  const std::size_t n = std::min({a_B.size(), b_B.size(), out.size()});
  const auto* mesh = std::get_if<MeshShape>(&shape);
  // a spent work budget stops the batch: its answers are thrown away (WorkMeter)
  if (mesh == nullptr) {
    for (std::size_t i = 0; i < n && !geometry::WorkMeter::Exhausted(); ++i) {
      out[i] = SweepSphereShape(shape, a_B[i], b_B[i], 0);
    }
    return;
  }
  // the backend's batch (Embree's packets) finds each segment's first crossing; the
  // point sweep decides the rest
  std::array<geometry::SegmentMeshHit, 64> hits;
  const geometry::TriangleMesh& triangles = mesh->bvh->mesh();
  for (std::size_t first = 0; first < n && !geometry::WorkMeter::Exhausted(); first += hits.size()) {
    const std::size_t count = std::min(hits.size(), n - first);
    BackendOf(*mesh).first_segment_hits(*mesh, a_B.subspan(first, count), b_B.subspan(first, count),
                                        std::span(hits).first(count));
    for (std::size_t k = 0; k < count; ++k) {
      const std::size_t i = first + k;
      const geometry::SegmentMeshHit& hit = hits[k];
      // a segment touching the surface where it starts hits by the closed-set rule; a
      // ray does only when it goes into the solid: the point sweep decides
      if (!hit.hit || hit.t == 0) {
        out[i] = hit.hit ? SweepSphereShape(shape, a_B[i], b_B[i], 0) : ShapeSweep{};
        continue;
      }
      ShapeSweep& sweep = out[i];
      sweep = {};
      sweep.hit = true;
      sweep.t = hit.t;
      sweep.point_B = a_B[i] + hit.t * (b_B[i] - a_B[i]);
      // the face normal, turned towards the segment's origin
      sweep.normal_B = triangles.face_normal(hit.triangle);
      if (sweep.normal_B.dot(a_B[i] - sweep.point_B) < 0) sweep.normal_B = -sweep.normal_B;
      sweep.triangle = hit.triangle;
    }
  }
}

int FindShapeFeatures(const scene::Shape& shape, const Vector3& p_B, double radius,
                      std::span<geometry::SphereMeshContact> out) {
  const RepresentationQueries* row = RowOf(shape);
  if (row == nullptr || !p_B.allFinite() || !(radius >= 0) || !std::isfinite(radius)) return 0;
  return row->features(shape, p_B, radius, out);
}

Vector3 CalcShadingNormal(const scene::Shape& shape, int triangle, const Vector3& point_B,
                          const Vector3& normal_B) {
  if (scene::TypeOf(shape) != scene::ShapeType::kMesh || triangle < 0) return normal_B;
  const geometry::TriangleMesh& mesh = std::get<MeshShape>(shape).bvh->mesh();
  const geometry::ClosestPointOnTriangle on =
      geometry::FindClosestPointOnTriangle(point_B, mesh.triangle(triangle));
  const auto& corners = mesh.triangles()[triangle];
  const Vector3 interpolated = (1 - on.u - on.v) * mesh.vertex_pseudo_normal(corners[0]) +
                               on.u * mesh.vertex_pseudo_normal(corners[1]) +
                               on.v * mesh.vertex_pseudo_normal(corners[2]);
  const Vector3 shading = UnitOr(interpolated, normal_B);
  // touched from behind (an open mesh's back), the vertex normals point away: keep the
  // geometric normal
  return shading.dot(normal_B) > 0 ? shading : normal_B;
}

}  // namespace hapticd::query
