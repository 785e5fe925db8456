#include "server/geometry/mesh_mesh_contacts.h"

#include <algorithm>

#include "server/geometry/triangle_triangle.h"

namespace hapticd::geometry {
namespace {

// One child slot of a BVH node: the unit the simultaneous descent works on.
struct Slot {
  int node;
  int child;
};

// Every box of B moved into A's frame is widened by this much (relative to the
// magnitudes involved) so that it still holds B's triangles after their vertices are
// moved with rounding.
constexpr double kTransformSlack = 1e-12;

// The pose, with |R| for bounding moved boxes.
struct Pose {
  Matrix3 rotation;
  Matrix3 abs_rotation;
  Vector3 translation;
  const Eigen::Isometry3d& X_AB;

  explicit Pose(const Eigen::Isometry3d& X)
      : rotation(X.linear()), abs_rotation(X.linear().cwiseAbs()), translation(X.translation()),
        X_AB(X) {}

  // The box (in A) around box `box` of B moved into A: centre R c + t, half extents
  // |R| e, widened for rounding.
  Aabb Move(const Aabb& box) const {
    const Vector3 center = 0.5 * (box.min + box.max);
    const Vector3 half = 0.5 * (box.max - box.min);
    const Vector3 moved_center = rotation * center + translation;
    const Vector3 moved_half = abs_rotation * half;
    const double slack =
        kTransformSlack * (moved_center.cwiseAbs().maxCoeff() + moved_half.maxCoeff() +
                           translation.cwiseAbs().maxCoeff() + center.cwiseAbs().maxCoeff() +
                           half.maxCoeff());
    return {moved_center - moved_half - Vector3::Constant(slack),
            moved_center + moved_half + Vector3::Constant(slack)};
  }
  Triangle Move(const Triangle& t) const { return {X_AB * t.v0, X_AB * t.v1, X_AB * t.v2}; }
};

// Calls visit(triangle of A, triangle of B moved into A, original indices) for every
// pair whose boxes overlap, until visit returns false.
template <typename PairVisitor>
void TraverseMeshPairs(const MeshBvh& a, const MeshBvh& b, const Pose& pose, PairVisitor visit) {
  const std::vector<BvhNode>& nodes_a = a.nodes();
  const std::vector<BvhNode>& nodes_b = b.nodes();

  // each entry: a slot of A and a slot of B whose boxes overlap; a step opens one
  // slot and stacks at most kBvhWidth pairs
  struct Entry {
    Slot a, b;
  };
  Entry stack[(kBvhWidth - 1) * 2 * kMaxBvhDepth + kBvhWidth * kBvhWidth];
  int top = 0;
  for (int ca = 0; ca < kBvhWidth; ++ca) {
    for (int cb = 0; cb < kBvhWidth; ++cb) {
      if (nodes_a[0].is_empty(ca) || nodes_b[0].is_empty(cb)) continue;
      if (AabbsOverlap(nodes_a[0].child_bounds(ca), pose.Move(nodes_b[0].child_bounds(cb)))) {
        stack[top++] = {{0, ca}, {0, cb}};
      }
    }
  }
  while (top > 0) {
    const Entry e = stack[--top];
    const BvhNode& node_a = nodes_a[e.a.node];
    const BvhNode& node_b = nodes_b[e.b.node];
    const Aabb box_a = node_a.child_bounds(e.a.child);
    const Aabb box_b = pose.Move(node_b.child_bounds(e.b.child));
    const bool leaf_a = node_a.is_leaf(e.a.child);
    const bool leaf_b = node_b.is_leaf(e.b.child);

    // two leaves: test their triangles
    if (leaf_a && leaf_b) {
      const int first_a = node_a.first_primitive(e.a.child);
      const int first_b = node_b.first_primitive(e.b.child);
      for (int j = first_b; j < first_b + node_b.count[e.b.child]; ++j) {
        const Triangle tb = pose.Move(b.primitive(j));
        const Aabb tb_box = Aabb::OfTriangle(tb);
        for (int i = first_a; i < first_a + node_a.count[e.a.child]; ++i) {
          const Triangle& ta = a.primitive(i);
          if (!AabbsOverlap(Aabb::OfTriangle(ta), tb_box)) continue;
          if (!visit(ta, tb, a.primitive_triangle(i), b.primitive_triangle(j))) return;
        }
      }
      continue;
    }
    // otherwise open the larger box (or the one that is not a leaf)
    const bool split_a = !leaf_a && (leaf_b || box_a.surface_area() >= box_b.surface_area());
    if (split_a) {
      const int child = node_a.child[e.a.child];
      for (int c = 0; c < kBvhWidth; ++c) {
        if (nodes_a[child].is_empty(c)) continue;
        if (AabbsOverlap(nodes_a[child].child_bounds(c), box_b)) stack[top++] = {{child, c}, e.b};
      }
    } else {
      const int child = node_b.child[e.b.child];
      for (int c = 0; c < kBvhWidth; ++c) {
        if (nodes_b[child].is_empty(c)) continue;
        if (AabbsOverlap(box_a, pose.Move(nodes_b[child].child_bounds(c)))) {
          stack[top++] = {e.a, {child, c}};
        }
      }
    }
  }
}

bool IsFinitePose(const Eigen::Isometry3d& X_AB) { return X_AB.matrix().allFinite(); }

}  // namespace

MeshMeshContacts FindMeshMeshContacts(const MeshBvh& a, const MeshBvh& b,
                                      const Eigen::Isometry3d& X_AB,
                                      std::span<MeshMeshContact> out) {
  MeshMeshContacts result;
  if (!IsFinitePose(X_AB)) return result;
  TraverseMeshPairs(a, b, Pose(X_AB), [&](const Triangle& ta, const Triangle& tb, int ia, int ib) {
    const TriangleIntersection x = IntersectTriangles(ta, tb);
    if (!x.intersect) return true;
    ++result.num_pairs;
    // buffer full: count only
    if (result.count == static_cast<int>(out.size())) {
      result.truncated = true;
      return true;
    }
    out[result.count++] = {ia, ib, x.coplanar, x.p0, x.p1};
    return true;
  });
  return result;
}

bool MeshesIntersect(const MeshBvh& a, const MeshBvh& b, const Eigen::Isometry3d& X_AB) {
  bool found = false;
  if (!IsFinitePose(X_AB)) return found;
  TraverseMeshPairs(a, b, Pose(X_AB), [&](const Triangle& ta, const Triangle& tb, int, int) {
    found = TrianglesIntersect(ta, tb);
    return !found;
  });
  return found;
}

}  // namespace hapticd::geometry
