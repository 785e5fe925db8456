#pragma once

// Broad phase for many moving objects: a dynamic AABB tree (after Box2D's
// b2DynamicTree, itself after Bullet's btDbvt).
//
// Theory of operation. Each object is a proxy: a leaf that stores the object's own
// box and a "fat" copy grown by a margin (and stretched along its last displacement).
// While the object's box stays inside its fat box, Move changes nothing in the tree,
// so small motions cost O(1). Otherwise the leaf is taken out and reinserted:
// insertion walks down from the root choosing the child by the surface area heuristic
// (the cheapest growth of the surface area, the expected cost of a random query), and
// on the way back up tree rotations shrink the boxes while keeping the two subtrees
// of every node within two levels of height (a relaxed AVL rule), so the height stays
// below 1.81 log2(n) + 2 whatever the motion.
//
//          root                internal node: union of its children's fat boxes
//         /    \               (two children, unordered)
//       n1      leaf 3         leaf: fat box (in the tree) + own box (for answers)
//      /  \                    (the proxy id is the leaf's node index)
//  leaf 0  leaf 7
//
// Queries prune with the fat boxes and answer with the objects' own boxes, so their
// answers equal a brute-force test of the own boxes, exactly (closed boxes: touching
// counts). Nodes live in one preallocated array with a free list; proxy ids are node
// indices and stay valid until removed.

#include <type_traits>
#include <vector>

#include "server/geometry/aabb.h"

namespace hapticd::geometry {

// Two proxies whose boxes overlap; a < b.
struct ProxyPair {
  int a = -1;
  int b = -1;
};

class DynamicAabbTree {
 public:
  static constexpr int kNullNode = -1;
  // Depth-first walks leave at most one node behind per level: height + 2 entries, and
  // the height stays below 1.81 log2(n) + 2 (< 62 for n < 2^31).
  static constexpr int kMaxWalk = 64;

  // Preallocates room for capacity proxies (2 capacity - 1 nodes); more proxies grow
  // the storage (an allocation). margin >= 0 fattens every box, in metres.
  DynamicAabbTree(int capacity, double margin);

  // Adds an object with box `box` (not empty, finite) and returns its proxy id.
  // Allocates only when more than `capacity` proxies are alive.
  int Insert(const Aabb& box);

  // Removes a proxy; its id may be reused by a later Insert. False (and nothing done)
  // when proxy is not a live proxy id.
  bool Remove(int proxy);

  // Sets a proxy's box. The tree changes only when the box leaves the fat box, or the
  // fat box has grown far larger than needed; then the new fat box is the box grown
  // by the margin and stretched by 2 * displacement (the expected next motion).
  // Returns true when the leaf was reinserted, false when it stayed (or the id is not
  // live).
  bool Move(int proxy, const Aabb& box, const Vector3& displacement = Vector3::Zero());

  // Writes every pair of proxies whose boxes overlap, each pair once, a < b, in no
  // particular order. Allocation-free while pairs->capacity() suffices.
  void FindOverlappingPairs(std::vector<ProxyPair>* pairs) const;

  // Writes the proxies whose boxes overlap `box`, in no particular order.
  // Allocation-free while proxies->capacity() suffices. An empty box finds nothing.
  void Query(const Aabb& box, std::vector<int>* proxies) const;

  // Calls visit(proxy) for each proxy whose box overlaps `box`, in no particular order;
  // a visit that returns false ends the walk. Never allocates (real-time safe): the
  // walk's stack holds height + 2 entries, and the height rule keeps that under
  // kMaxWalk for any number of proxies an int can count.
  template <typename Visit>
  void ForEachOverlap(const Aabb& box, Visit visit) const {
    if (root_ == kNullNode) return;
    int stack[kMaxWalk];
    int top = 0;
    stack[top++] = root_;
    while (top > 0) {
      const int index = stack[--top];
      const Node& node = nodes_[index];
      if (!AabbsOverlap(node.box, box)) continue;
      if (node.child0 == kNullNode) {
        // a leaf: answer with the object's own box
        if (!AabbsOverlap(boxes_[index], box)) continue;
        if constexpr (std::is_same_v<decltype(visit(index)), bool>) {
          if (!visit(index)) return;
        } else {
          visit(index);
        }
      } else {
        stack[top++] = node.child0;
        stack[top++] = node.child1;
      }
    }
  }

  // True when proxy is the id of a live proxy.
  bool contains(int proxy) const {
    return proxy >= 0 && proxy < static_cast<int>(nodes_.size()) && nodes_[proxy].height == 0;
  }
  // The box given to Insert/Move and the fat box the tree holds. proxy must be live.
  const Aabb& box(int proxy) const { return boxes_[proxy]; }
  const Aabb& fat_box(int proxy) const { return nodes_[proxy].box; }
  int size() const { return proxy_count_; }
  // Height of the tree: 0 for a single leaf, -1 when empty.
  int height() const { return root_ == kNullNode ? -1 : nodes_[root_].height; }
  double margin() const { return margin_; }

  // Checks the structure (for tests): parent links, heights, the height rule, every
  // internal box equal to the union of its children's, every fat box holding its own
  // box, and the node count. True when all hold.
  bool CheckInvariants() const;

 private:
  struct Node {
    // Leaf: the fat box; internal: the union of the children's boxes.
    Aabb box;
    // The parent, or the next free node while on the free list.
    int parent = kNullNode;
    int child0 = kNullNode;
    int child1 = kNullNode;
    // 0 for a leaf, 1 + the children's maximum for an internal node, -1 when free.
    int height = -1;
  };

  bool is_leaf(int node) const { return nodes_[node].child0 == kNullNode; }

  int AllocateNode();
  void FreeNode(int node);
  Aabb Fatten(const Aabb& box, const Vector3& displacement) const;
  void InsertLeaf(int leaf);
  void RemoveLeaf(int leaf);
  // Recomputes boxes and heights from node up to the root, rotating on the way.
  void RefitUpwards(int node);
  // Restores the height rule at node (children's heights within 2) by a rotation, or
  // else improves its area by a swap; returns the subtree's new root.
  int Balance(int node);
  int RotateUp(int node, int up, int keep);
  void SwapForArea(int node);
  void Refit(int node);
  void ReplaceChild(int parent, int old_child, int new_child);
  int CheckSubtree(int node, int parent, bool* ok) const;

  double margin_ = 0;
  std::vector<Node> nodes_;
  // The objects' own boxes, indexed like nodes_ (meaningful for leaves).
  std::vector<Aabb> boxes_;
  int root_ = kNullNode;
  int free_list_ = kNullNode;
  int proxy_count_ = 0;
  int node_count_ = 0;
};

}  // namespace hapticd::geometry
