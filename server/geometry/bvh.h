#pragma once

// A bounding volume hierarchy over the non-degenerate triangles of a TriangleMesh:
// built top-down with a binned surface area heuristic (Wald 2007, "On fast
// construction of SAH-based bounding volume hierarchies"), 4 children per node (the
// node holds their boxes: 128 bytes, two cache lines, per step of a traversal, which
// matters once the tree outgrows the caches), stored as a flat array in depth-first
// order, with small leaves.
//
// Boxes are float, rounded outwards from the double-precision triangles, so every box
// contains everything below it exactly; queries then decide on the double-precision
// triangles, which the BVH keeps in leaf order beside the original indices.
//
// Immutable once built; queries (mesh_queries.h) may run from any number of threads.

#include <cstdint>
#include <memory>
#include <vector>

#include "server/geometry/aabb.h"
#include "server/geometry/triangle_mesh.h"
#include "server/geometry/types.h"

namespace hapticd::geometry {

// Longest root-to-leaf path, in internal nodes: traversal stacks of
// (kBvhWidth - 1) x kMaxBvhDepth entries never overflow.
constexpr int kMaxBvhDepth = 64;

struct BvhBuildOptions {
  // Largest leaf (1..16); the SAH may choose smaller ones.
  int max_leaf_size = 4;
  // Threads for the build (>= 1); the children of the top node are shared between
  // two threads, recursively.
  int num_threads = 2;
};

// Children per node: each node holds the boxes of up to this many children, so that a
// traversal tests them together and descends two levels of a binary tree per step.
constexpr int kBvhWidth = 4;

// One internal node: the boxes of its children and where to find them.
// Child c is an internal node when child[c] >= 0 (its index in nodes()), else a leaf
// holding primitives [~child[c], ~child[c] + count[c]) of the BVH's leaf order. Unused
// slots are leaves with count 0 and an empty box (lo = +inf, hi = -inf).
struct alignas(64) BvhNode {
  // lo[axis][c] and hi[axis][c]: box of child c, float, rounded outwards.
  float lo[3][kBvhWidth];
  float hi[3][kBvhWidth];
  int32_t child[kBvhWidth];
  int32_t count[kBvhWidth];

  bool is_leaf(int c) const { return child[c] < 0; }
  bool is_empty(int c) const { return child[c] < 0 && count[c] == 0; }
  int first_primitive(int c) const { return ~child[c]; }
  Aabb child_bounds(int c) const {
    return {Vector3(lo[0][c], lo[1][c], lo[2][c]), Vector3(hi[0][c], hi[1][c], hi[2][c])};
  }
};
static_assert(sizeof(BvhNode) == 32 * kBvhWidth);

// A second bound of a node's children, beside their boxes, for the queries that ask what
// lies near a piece of surface (sphere_sweep.h: the gather of triangles near a sphere
// avatar, and the sphere sweep through a whole mesh): a thick disc about each child,
// its centre (the mean of the child's corners) and unit normal (its triangles' summed
// area normal), in float, and its radius within its plane and half-thickness along its
// normal. Where a sphere rests on a curved surface, the triangles a little beside the
// contact lie much nearer it by their boxes than they are, and the box test keeps a ring
// of them; their discs pass most of that ring over (the gather of the finger proxy on
// 1.3M triangles: 404 -> 163 units of work, 8.7 -> 5.4 us).
//
// Only a child of at most kMaxDiscTriangles triangles gets a disc (higher up they are
// loose, and the boxes prune there; 64 prunes as well as 256 and builds faster); the
// others, and empty slots, get one of infinite radius and thickness, which passes nothing
// over. Radius and thickness are computed in double from every corner in the child, with
// the centre and normal as stored, and rounded up to float: the disc holds the child's
// triangles exactly but for the normal being unit only to float precision (a relative
// 1e-7, which users of the disc cover with their slack). 128 bytes a node, as much as
// the boxes.
struct alignas(64) BvhDiscs {
  float centre[3][kBvhWidth];
  float normal[3][kBvhWidth];
  float radius[kBvhWidth];
  float thickness[kBvhWidth];  // half of it: the disc is |normal . (x - centre)| <= this
};
static_assert(sizeof(BvhDiscs) == 32 * kBvhWidth);

constexpr int kMaxDiscTriangles = 64;

// The largest float <= x and the smallest float >= x, clamped to the finite floats: how
// the boxes are rounded outwards (a node side at +-FLT_MAX stands for everything beyond
// and is widened to infinity), and how float queries round their own boxes.
float RoundDownToFloat(double x);
float RoundUpToFloat(double x);

class MeshBvh {
 public:
  // Builds the hierarchy over mesh->nondegenerate_triangles(); the BVH shares ownership
  // of the mesh. Throws std::invalid_argument on a null mesh or options out of range
  // (and passes on std::bad_alloc, or std::system_error when no thread can start).
  explicit MeshBvh(std::shared_ptr<const TriangleMesh> mesh, const BvhBuildOptions& options = {});

  const TriangleMesh& mesh() const { return *mesh_; }
  const std::shared_ptr<const TriangleMesh>& shared_mesh() const { return mesh_; }

  // Root is nodes()[0]; there is always at least one node.
  const std::vector<BvhNode>& nodes() const { return nodes_; }
  // discs()[i]: the discs about nodes()[i]'s children.
  const std::vector<BvhDiscs>& discs() const { return discs_; }
  // Box around everything (the union of the root's child boxes).
  Aabb bounds() const;
  // Internal nodes on the longest root-to-leaf path (1 for a lone root), <= kMaxBvhDepth.
  int depth() const { return depth_; }

  // Primitives in leaf order: the triangle's corners and its original mesh index.
  int num_primitives() const { return static_cast<int>(primitive_triangles_.size()); }
  const Triangle& primitive(int i) const { return primitives_[i]; }
  int primitive_triangle(int i) const { return primitive_triangles_[i]; }

 private:
  std::shared_ptr<const TriangleMesh> mesh_;
  std::vector<BvhNode> nodes_;
  std::vector<BvhDiscs> discs_;
  std::vector<Triangle> primitives_;
  std::vector<int> primitive_triangles_;
  int depth_ = 0;
};

}  // namespace hapticd::geometry
