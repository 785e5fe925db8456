#include "server/geometry/broad_phase.h"

#include <algorithm>
#include <array>
#include <cstdlib>

namespace hapticd::geometry {
namespace {

// How far ahead Move stretches a fat box: this many displacements.
constexpr double kDisplacementMultiplier = 2;
// A fat box larger than a fresh one grown by this many margins is refreshed.
constexpr double kHugeMarginFactor = 4;
// The most two sibling subtrees' heights may differ (see Balance).
constexpr int kMaxLean = 2;
// Traversal stacks live on the C++ stack up to this many entries. The traversals need
// at most 4 height + 4 entries and the height stays under 60 (see Balance); a taller
// tree (impossible while the height rule holds) would fall back to a heap stack.
constexpr int kFixedStackSize = 256;

Aabb Union(const Aabb& a, const Aabb& b) {
  return {a.min.cwiseMin(b.min), a.max.cwiseMax(b.max)};
}

}  // namespace

DynamicAabbTree::DynamicAabbTree(int capacity, double margin) : margin_(margin) {
  const int nodes = 2 * std::max(capacity, 1);
  nodes_.resize(nodes);
  boxes_.resize(nodes);
  // Chain every node into the free list, lowest index first.
  for (int i = 0; i < nodes; ++i) nodes_[i].parent = i + 1 < nodes ? i + 1 : kNullNode;
  free_list_ = 0;
}

int DynamicAabbTree::AllocateNode() {
  // Out of nodes: double the storage (the only allocation) and chain the new ones.
  if (free_list_ == kNullNode) {
    const int old_size = static_cast<int>(nodes_.size());
    const int new_size = 2 * old_size;
    nodes_.resize(new_size);
    boxes_.resize(new_size);
    for (int i = old_size; i < new_size; ++i) {
      nodes_[i].parent = i + 1 < new_size ? i + 1 : kNullNode;
    }
    free_list_ = old_size;
  }
  const int node = free_list_;
  free_list_ = nodes_[node].parent;
  nodes_[node] = Node{};
  nodes_[node].height = 0;
  ++node_count_;
  return node;
}

void DynamicAabbTree::FreeNode(int node) {
  nodes_[node] = Node{};
  nodes_[node].parent = free_list_;
  free_list_ = node;
  --node_count_;
}

Aabb DynamicAabbTree::Fatten(const Aabb& box, const Vector3& displacement) const {
  Aabb fat = box.Inflated(margin_);
  // Stretch towards the motion only.
  const Vector3 ahead = kDisplacementMultiplier * displacement;
  fat.min += ahead.cwiseMin(0.0);
  fat.max += ahead.cwiseMax(0.0);
  return fat;
}

int DynamicAabbTree::Insert(const Aabb& box) {
  const int leaf = AllocateNode();
  nodes_[leaf].box = Fatten(box, Vector3::Zero());
  boxes_[leaf] = box;
  InsertLeaf(leaf);
  ++proxy_count_;
  return leaf;
}

bool DynamicAabbTree::Remove(int proxy) {
  if (!contains(proxy)) return false;
  RemoveLeaf(proxy);
  FreeNode(proxy);
  --proxy_count_;
  return true;
}

bool DynamicAabbTree::Move(int proxy, const Aabb& box, const Vector3& displacement) {
  if (!contains(proxy)) return false;
  boxes_[proxy] = box;
  const Aabb fat = Fatten(box, displacement);
  const Aabb& current = nodes_[proxy].box;
  // Still inside a fat box that is not much larger than needed: nothing to do.
  if (current.Contains(box) && fat.Inflated(kHugeMarginFactor * margin_).Contains(current)) {
    return false;
  }
  // Otherwise reinsert the leaf with a fresh fat box (frees one node, takes one).
  RemoveLeaf(proxy);
  nodes_[proxy].box = fat;
  InsertLeaf(proxy);
  return true;
}

void DynamicAabbTree::ReplaceChild(int parent, int old_child, int new_child) {
  if (parent == kNullNode) {
    root_ = new_child;
  } else if (nodes_[parent].child0 == old_child) {
    nodes_[parent].child0 = new_child;
  } else {
    nodes_[parent].child1 = new_child;
  }
}

// Surface area heuristic (Goldsmith & Salmon 1987, as in Box2D): at each internal node
// on the way down, compare the cost of making the leaf a sibling of this node (a new
// parent with twice the combined area) with the least cost of sending it into a
// child, which grows every ancestor ("inheritance") and the child's own box.
void DynamicAabbTree::InsertLeaf(int leaf) {
  // Empty tree: the leaf is the root.
  if (root_ == kNullNode) {
    root_ = leaf;
    nodes_[leaf].parent = kNullNode;
    return;
  }
  const Aabb leaf_box = nodes_[leaf].box;
  const auto descend_cost = [&](int child) {
    const double grown = Union(leaf_box, nodes_[child].box).surface_area();
    return is_leaf(child) ? grown : grown - nodes_[child].box.surface_area();
  };
  // Walk down to the best sibling.
  int index = root_;
  while (!is_leaf(index)) {
    const Node& node = nodes_[index];
    const double area = node.box.surface_area();
    const double combined_area = Union(node.box, leaf_box).surface_area();
    const double cost = 2 * combined_area;
    const double inheritance = 2 * (combined_area - area);
    const double cost0 = descend_cost(node.child0) + inheritance;
    const double cost1 = descend_cost(node.child1) + inheritance;
    if (cost < cost0 && cost < cost1) break;
    index = cost0 < cost1 ? node.child0 : node.child1;
  }

  // A new parent joins the sibling and the leaf.
  const int sibling = index;
  const int old_parent = nodes_[sibling].parent;
  const int new_parent = AllocateNode();
  Node& parent = nodes_[new_parent];
  parent.parent = old_parent;
  parent.box = Union(leaf_box, nodes_[sibling].box);
  parent.height = nodes_[sibling].height + 1;
  parent.child0 = sibling;
  parent.child1 = leaf;
  ReplaceChild(old_parent, sibling, new_parent);
  nodes_[sibling].parent = new_parent;
  nodes_[leaf].parent = new_parent;
  RefitUpwards(new_parent);
}

void DynamicAabbTree::RemoveLeaf(int leaf) {
  // The only leaf: the tree becomes empty.
  if (leaf == root_) {
    root_ = kNullNode;
    return;
  }
  // The sibling takes the parent's place; the parent node is freed.
  const int parent = nodes_[leaf].parent;
  const int grand = nodes_[parent].parent;
  const int sibling = nodes_[parent].child0 == leaf ? nodes_[parent].child1 : nodes_[parent].child0;
  ReplaceChild(grand, parent, sibling);
  nodes_[sibling].parent = grand;
  FreeNode(parent);
  RefitUpwards(grand);
}

void DynamicAabbTree::Refit(int node) {
  Node& n = nodes_[node];
  n.height = 1 + std::max(nodes_[n.child0].height, nodes_[n.child1].height);
  n.box = Union(nodes_[n.child0].box, nodes_[n.child1].box);
}

void DynamicAabbTree::RefitUpwards(int node) {
  while (node != kNullNode) {
    node = Balance(node);
    Refit(node);
    node = nodes_[node].parent;
  }
}

// Balance. Every internal node keeps its children's heights within kMaxLean (2) of
// each other, a relaxed AVL rule: a tree of height h then holds at least N(h) leaves
// with N(h) = N(h - 1) + N(h - 3), so h <= 1.81 log2(n) + 2 (under 60 for any int n).
// Within that rule the tree is free to follow the surface area heuristic, which
// makes far better trees for the pair search than strict AVL (about half the node
// pairs visited in bench/broad_phase_bench.cc).
int DynamicAabbTree::Balance(int a) {
  if (is_leaf(a)) return a;
  const int b = nodes_[a].child0;
  const int c = nodes_[a].child1;
  const int lean = nodes_[c].height - nodes_[b].height;
  // Too unbalanced: a forced rotation.
  if (std::abs(lean) > kMaxLean) return RotateUp(a, lean > 0 ? c : b, lean > 0 ? b : c);
  // Balanced: a swap that shrinks the surface area, where one keeps the rule.
  SwapForArea(a);
  return a;
}

// Forced rotation. With A's children B (keep) and C (up), C at least kMaxLean + 1
// taller, C takes A's place and A keeps B plus C's shorter child G, while the taller
// one F stays under C:
//
//       A                C        h(B) < h(C) - kMaxLean
//     /   \            /   \      h(F) >= h(G)
//    B     C    =>    A     F
//         / \        / \      A (rebalanced), then C refit
//        F   G      B   G
//
// Children are unordered, so no double rotation is needed. With h(C) = m: h(F) = m - 1
// and m - 1 - kMaxLean <= h(G) <= m - 1, and h(B) <= h(G). A may still lean too far
// (B much shorter than G, as when the SAH pairs a new leaf with a tall subtree), so it
// is balanced again, recursively one level lower; by induction that leaves A balanced
// with height h(G) or h(G) + 1, so C is balanced and its height is m or m + 1. Where
// F and G are equally tall, A takes the one nearer B (the smaller union).
int DynamicAabbTree::RotateUp(int a, int up, int keep) {
  const int f0 = nodes_[up].child0;
  const int f1 = nodes_[up].child1;
  int shorter = nodes_[f0].height < nodes_[f1].height ? f0 : f1;
  if (nodes_[f0].height == nodes_[f1].height) {
    const double area0 = Union(nodes_[keep].box, nodes_[f0].box).surface_area();
    const double area1 = Union(nodes_[keep].box, nodes_[f1].box).surface_area();
    shorter = area0 <= area1 ? f0 : f1;
  }
  const int taller = shorter == f0 ? f1 : f0;

  // `up` replaces A under A's parent.
  const int a_parent = nodes_[a].parent;
  ReplaceChild(a_parent, a, up);
  nodes_[up].parent = a_parent;
  // `up` adopts A and keeps its taller child; A keeps `keep` and takes the shorter.
  nodes_[up].child0 = a;
  nodes_[up].child1 = taller;
  nodes_[a].parent = up;
  nodes_[a].child0 = keep;
  nodes_[a].child1 = shorter;
  nodes_[shorter].parent = a;
  Refit(Balance(a));
  Refit(up);
  return up;
}

// Tree rotation for area (Kopta et al. 2012, as in Box2D 3): swap a child X of A with
// a grandchild on the other side (a child of A's other child Y), so Y holds X and the
// grandchild that stays. A's box is unchanged; Y's box shrinks by the gain. The best
// of the (up to) four swaps is applied when it gains and keeps the height rule at Y
// and at A.
void DynamicAabbTree::SwapForArea(int a) {
  const auto height = [this](int node) { return nodes_[node].height; };
  double best_gain = 0;
  int best_x = kNullNode;
  int best_up = kNullNode;
  int best_y = kNullNode;
  for (const int x : {nodes_[a].child0, nodes_[a].child1}) {
    const int y = nodes_[a].child0 == x ? nodes_[a].child1 : nodes_[a].child0;
    // A leaf sibling has no grandchildren to swap with.
    if (is_leaf(y)) continue;
    const double area_y = nodes_[y].box.surface_area();
    for (const int up : {nodes_[y].child0, nodes_[y].child1}) {
      const int stay = nodes_[y].child0 == up ? nodes_[y].child1 : nodes_[y].child0;
      const double gain = area_y - Union(nodes_[x].box, nodes_[stay].box).surface_area();
      if (!(gain > best_gain)) continue;
      const int new_y_height = 1 + std::max(height(x), height(stay));
      if (std::abs(height(x) - height(stay)) > kMaxLean) continue;
      if (std::abs(new_y_height - height(up)) > kMaxLean) continue;
      best_gain = gain;
      best_x = x;
      best_up = up;
      best_y = y;
    }
  }
  // No swap gains: leave A as it is.
  if (best_x == kNullNode) return;
  ReplaceChild(a, best_x, best_up);
  nodes_[best_up].parent = a;
  ReplaceChild(best_y, best_up, best_x);
  nodes_[best_x].parent = best_y;
  Refit(best_y);
}

void DynamicAabbTree::FindOverlappingPairs(std::vector<ProxyPair>* pairs) const {
  pairs->clear();
  if (root_ == kNullNode) return;
  // Stack of node pairs; (n, n) stands for "pairs within the subtree n". Bound: a
  // "within" task leaves at most two tasks behind per level (<= 2 height), a "between"
  // task one per level of either subtree (<= 2 height).
  struct Task {
    int a;
    int b;
  };
  std::array<Task, kFixedStackSize> fixed_stack;
  std::vector<Task> heap_stack;
  Task* stack = fixed_stack.data();
  const int needed = 4 * height() + 4;
  if (needed > kFixedStackSize) {
    heap_stack.resize(needed);
    stack = heap_stack.data();
  }
  int top = 0;
  stack[top++] = {root_, root_};
  while (top > 0) {
    const Task task = stack[--top];
    const Node& na = nodes_[task.a];
    // Within one subtree: pairs inside each child, then pairs between them.
    if (task.a == task.b) {
      if (na.child0 == kNullNode) continue;
      stack[top++] = {na.child0, na.child0};
      stack[top++] = {na.child1, na.child1};
      stack[top++] = {na.child0, na.child1};
      continue;
    }
    // Between two disjoint subtrees: prune on the fat boxes.
    const Node& nb = nodes_[task.b];
    if (!AabbsOverlap(na.box, nb.box)) continue;
    const bool leaf_a = na.child0 == kNullNode;
    const bool leaf_b = nb.child0 == kNullNode;
    // Two leaves: answer with the objects' own boxes.
    if (leaf_a && leaf_b) {
      if (AabbsOverlap(boxes_[task.a], boxes_[task.b])) {
        pairs->push_back({std::min(task.a, task.b), std::max(task.a, task.b)});
      }
      continue;
    }
    // Otherwise descend into the taller subtree (or the only internal one).
    if (leaf_a || (!leaf_b && nb.height > na.height)) {
      stack[top++] = {task.a, nb.child0};
      stack[top++] = {task.a, nb.child1};
    } else {
      stack[top++] = {na.child0, task.b};
      stack[top++] = {na.child1, task.b};
    }
  }
}

void DynamicAabbTree::Query(const Aabb& box, std::vector<int>* proxies) const {
  proxies->clear();
  ForEachOverlap(box, [proxies](int proxy) { proxies->push_back(proxy); });
}

int DynamicAabbTree::CheckSubtree(int node, int parent, bool* ok) const {
  const auto check = [ok](bool condition) {
    if (!condition) *ok = false;
    return condition;
  };
  if (!check(node >= 0 && node < static_cast<int>(nodes_.size()))) return 0;
  const Node& n = nodes_[node];
  check(n.parent == parent);
  // A leaf: fat box around the object's box.
  if (n.child0 == kNullNode) {
    check(n.child1 == kNullNode && n.height == 0 && n.box.Contains(boxes_[node]));
    return 1;
  }
  // An internal node: balanced, exact height and box.
  const int count0 = CheckSubtree(n.child0, node, ok);
  const int count1 = CheckSubtree(n.child1, node, ok);
  if (!*ok) return 0;
  const int h0 = nodes_[n.child0].height;
  const int h1 = nodes_[n.child1].height;
  check(n.height == 1 + std::max(h0, h1) && std::abs(h0 - h1) <= kMaxLean);
  const Aabb expected = Union(nodes_[n.child0].box, nodes_[n.child1].box);
  check(n.box.min == expected.min && n.box.max == expected.max);
  return count0 + count1;
}

bool DynamicAabbTree::CheckInvariants() const {
  bool ok = true;
  const int leaves = root_ == kNullNode ? 0 : CheckSubtree(root_, kNullNode, &ok);
  ok = ok && leaves == proxy_count_;
  ok = ok && node_count_ == (proxy_count_ == 0 ? 0 : 2 * proxy_count_ - 1);
  // The free list holds every other node, without cycles (bounded walk).
  int free_nodes = 0;
  const int total = static_cast<int>(nodes_.size());
  for (int i = free_list_; i != kNullNode && free_nodes <= total; i = nodes_[i].parent) {
    ok = ok && nodes_[i].height == -1;
    ++free_nodes;
  }
  return ok && free_nodes + node_count_ == total;
}

}  // namespace hapticd::geometry
