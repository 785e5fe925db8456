#include "server/conformance/query_ops.h"

#include <array>
#include <limits>
#include <memory>
#include <stdexcept>

#include <fmt/format.h>

#include "server/embree/embree_mesh.h"
#include "server/geometry/aabb.h"
#include "server/geometry/box_box.h"
#include "server/geometry/bvh.h"
#include "server/geometry/convex_convex.h"
#include "server/geometry/mesh_queries.h"
#include "server/geometry/segment_triangle.h"
#include "server/geometry/sphere_sphere.h"
#include "server/geometry/triangle_triangle.h"
#include "server/query/mesh_backends.h"

namespace hapticd::conformance {
namespace {

namespace g = hapticd::geometry;

void WriteTriangleHit(const g::TriangleHit& hit, ResultWriter& result) {
  result.Bool("hit", hit.hit);
  if (!hit.hit) return;
  result.Number("t", hit.t);
  result.Number("u", hit.u);
  result.Number("v", hit.v);
}

g::Sphere ReadSphere(const JsonAt& at) {
  return {ReadVector3(at["center"]), ReadNonNegative(at["radius"])};
}

g::Aabb ReadAabb(const JsonAt& at) {
  const g::Aabb box{ReadVector3(at["min"]), ReadVector3(at["max"])};
  for (int axis = 0; axis < 3; ++axis) {
    if (box.min[axis] > box.max[axis]) {
      throw CaseError(fmt::format("{}.min[{}] = {} exceeds {}.max[{}] = {}", at.path, axis,
                                  box.min[axis], at.path, axis, box.max[axis]));
    }
  }
  return box;
}

g::Box ReadBox(const JsonAt& at) {
  g::Box box;
  box.center = ReadVector3(at["center"]);
  box.rotation = ReadRotation(at["rotation"]);
  const JsonAt half = at["half_extents"];
  box.half_extents = ReadVector3(half);
  for (int axis = 0; axis < 3; ++axis) ReadNonNegative(half[axis]);
  return box;
}

std::vector<Vector3> ReadConvexPoints(const JsonAt& at) {
  std::vector<Vector3> points = ReadPoints(at["points"]);
  if (points.empty()) throw CaseError(at.path + ".points is empty");
  return points;
}

// An inline mesh; TriangleMesh validates indices and drops zero-area triangles.
g::MeshBvh ReadMesh(const JsonAt& at) {
  std::vector<Vector3> vertices = ReadPoints(at["vertices"]);
  const JsonAt triangles = at["triangles"];
  std::vector<g::TriangleMesh::TriangleIndices> indices(triangles.size());
  for (int t = 0; t < triangles.size(); ++t) {
    const JsonAt corners = triangles[t];
    if (corners.size() != 3) {
      throw CaseError(fmt::format("{} must be [i, j, k]; it has {} elements", corners.path, corners.size()));
    }
    for (int k = 0; k < 3; ++k) {
      if (!corners[k].value.IsInt()) throw CaseError(corners[k].path + " must be an integer index");
      indices[t][k] = corners[k].value.GetInt();
    }
  }
  try {
    return g::MeshBvh(std::make_shared<const g::TriangleMesh>(std::move(vertices), std::move(indices)));
  } catch (const std::invalid_argument& e) {
    throw CaseError(fmt::format("{}: {}", at.path, e.what()));
  }
}

// A segment p -> q of non-zero length.
std::pair<Vector3, Vector3> ReadSegment(const JsonAt& args) {
  const Vector3 p = ReadVector3(args["p"]);
  const Vector3 q = ReadVector3(args["q"]);
  if (p == q) throw CaseError("args.p equals args.q: the segment has zero length");
  return {p, q};
}

void RayTriangle(const JsonAt& args, const QueryBackend&, ResultWriter& result) {
  const Vector3 origin = ReadVector3(args["origin"]);
  const Vector3 dir = ReadDirection(args["dir"]);
  const Triangle tri = ReadTriangle(args["tri"]);
  WriteTriangleHit(g::IntersectRayTriangleWatertight(origin, dir, tri), result);
}

void SegmentTriangle(const JsonAt& args, const QueryBackend&, ResultWriter& result) {
  const auto [p, q] = ReadSegment(args);
  const Triangle tri = ReadTriangle(args["tri"]);
  WriteTriangleHit(g::IntersectSegmentTriangleWatertight(p, q, tri), result);
}

void TriangleTriangle(const JsonAt& args, const QueryBackend&, ResultWriter& result) {
  const Triangle a = ReadTriangle(args["a"]);
  const Triangle b = ReadTriangle(args["b"]);
  result.Bool("intersect", g::TrianglesIntersect(a, b));
}

void SphereSphere(const JsonAt& args, const QueryBackend&, ResultWriter& result) {
  const g::SphereSphereResult r = g::CollideSpheres(ReadSphere(args["a"]), ReadSphere(args["b"]));
  result.Bool("intersect", r.intersect);
  result.Number("distance", r.distance);
}

void AabbAabb(const JsonAt& args, const QueryBackend&, ResultWriter& result) {
  result.Bool("intersect", g::AabbsOverlap(ReadAabb(args["a"]), ReadAabb(args["b"])));
}

void ObbObb(const JsonAt& args, const QueryBackend&, ResultWriter& result) {
  result.Bool("intersect", g::BoxesOverlap(ReadBox(args["a"]), ReadBox(args["b"])));
}

void ConvexConvex(const JsonAt& args, const QueryBackend&, ResultWriter& result) {
  const g::ConvexConvexResult r =
      g::CollideConvex(ReadConvexPoints(args["a"]), ReadConvexPoints(args["b"]));
  result.Bool("intersect", r.intersect);
  result.Number("distance", r.distance);
  result.Vector("normal", r.normal);
  result.Vector("point_a", r.point_a);
  result.Vector("point_b", r.point_b);
}

// The case's mesh on the chosen backend: its BVH, and its Embree scene when asked for.
scene::MeshShape ReadCaseMesh(const JsonAt& at, const QueryBackend& backend) {
  scene::MeshShape mesh;
  mesh.bvh = std::make_shared<const g::MeshBvh>(ReadMesh(at));
  if (backend.embree) mesh.embree = std::make_shared<const embree::EmbreeMesh>(backend.embree, mesh.bvh);
  return mesh;
}

void SegmentMesh(const JsonAt& args, const QueryBackend& backend, ResultWriter& result) {
  const scene::MeshShape mesh = ReadCaseMesh(args["mesh"], backend);
  const auto [p, q] = ReadSegment(args);
  const g::SegmentMeshHit hit = query::BackendOf(mesh).first_segment_hit(mesh, p, q);
  result.Bool("hit", hit.hit);
  if (!hit.hit) return;
  result.Number("t", hit.t);
  result.Int("triangle", hit.triangle);
}

void ClosestPointMesh(const JsonAt& args, const QueryBackend& backend, ResultWriter& result) {
  const scene::MeshShape mesh = ReadCaseMesh(args["mesh"], backend);
  const g::Vector3 point = ReadVector3(args["point"]);
  const g::MeshClosestPoint closest =
      query::BackendOf(mesh).closest_point(mesh, point, std::numeric_limits<double>::infinity());
  result.Number("distance", closest.distance);
  result.Vector("point", closest.point);
}

void PointInsideMesh(const JsonAt& args, const QueryBackend& backend, ResultWriter& result) {
  const scene::MeshShape mesh = ReadCaseMesh(args["mesh"], backend);
  if (!mesh.bvh->mesh().is_closed()) {
    throw CaseError("args.mesh is not closed: some edge is not shared by exactly two "
                    "consistently oriented triangles, so it has no inside");
  }
  const g::Vector3 point = ReadVector3(args["point"]);
  result.Bool("inside", query::BackendOf(mesh).is_inside(mesh, point));
}

struct NamedOp {
  std::string_view name;
  QueryOp op;
};

constexpr std::array kOps = {
    NamedOp{"ray_triangle", RayTriangle},     NamedOp{"segment_triangle", SegmentTriangle},
    NamedOp{"triangle_triangle", TriangleTriangle}, NamedOp{"sphere_sphere", SphereSphere},
    NamedOp{"aabb_aabb", AabbAabb},           NamedOp{"obb_obb", ObbObb},
    NamedOp{"convex_convex", ConvexConvex},   NamedOp{"segment_mesh", SegmentMesh},
    NamedOp{"closest_point_mesh", ClosestPointMesh}, NamedOp{"point_inside_mesh", PointInsideMesh},
};

}  // namespace

QueryOp FindQueryOp(std::string_view name) {
  for (const NamedOp& entry : kOps) {
    if (entry.name == name) return entry.op;
  }
  return nullptr;
}

}  // namespace hapticd::conformance
