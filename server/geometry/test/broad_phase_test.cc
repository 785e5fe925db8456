#include "server/geometry/broad_phase.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "server/geometry/aabb.h"

namespace hapticd::geometry {
namespace {

Aabb MakeBox(const Vector3& center, const Vector3& half) { return {center - half, center + half}; }

// ---- Aabb helpers (aabb.h) ----

TEST(AabbTest, TouchingFaceEdgeCornerOverlap) {
  const Aabb unit{{0, 0, 0}, {1, 1, 1}};
  EXPECT_TRUE(AabbsOverlap(unit, {{1, 0.25, 0.25}, {2, 0.75, 0.75}}));  // face
  EXPECT_TRUE(AabbsOverlap(unit, {{1, 1, 0.25}, {2, 2, 0.75}}));        // edge
  EXPECT_TRUE(AabbsOverlap(unit, {{1, 1, 1}, {2, 2, 2}}));              // corner
  EXPECT_TRUE(AabbsOverlap(unit, {{-1, -1, -1}, {0, 0, 0}}));           // corner, other side
  const double above = std::nextafter(1.0, 2.0);
  EXPECT_FALSE(AabbsOverlap(unit, {{above, 0, 0}, {2, 1, 1}}));
  EXPECT_FALSE(AabbsOverlap(unit, {{0, 0, above}, {1, 1, 2}}));
  // Symmetric, and a box overlaps itself and what it contains.
  EXPECT_TRUE(AabbsOverlap({{1, 1, 1}, {2, 2, 2}}, unit));
  EXPECT_TRUE(AabbsOverlap(unit, unit));
  EXPECT_TRUE(AabbsOverlap(unit, {{0.25, 0.25, 0.25}, {0.5, 0.5, 0.5}}));
}

TEST(AabbTest, EmptyBoxes) {
  const Aabb empty = Aabb::Empty();
  EXPECT_TRUE(empty.empty());
  EXPECT_EQ(empty.surface_area(), 0);
  const Aabb unit{{0, 0, 0}, {1, 1, 1}};
  EXPECT_FALSE(AabbsOverlap(empty, unit));
  EXPECT_FALSE(AabbsOverlap(unit, empty));
  EXPECT_FALSE(AabbsOverlap(empty, empty));
  EXPECT_FALSE(empty.Contains(Vector3(0, 0, 0)));
  // Inverted on one axis only is empty too.
  const Aabb inverted{{0, 1, 0}, {1, 0, 1}};
  EXPECT_TRUE(inverted.empty());
  EXPECT_EQ(inverted.surface_area(), 0);
  EXPECT_FALSE(AabbsOverlap(inverted, unit));
  EXPECT_FALSE(AabbsOverlap(unit, inverted));
  // A point box is not empty and overlaps what touches it.
  const Aabb point{{1, 1, 1}, {1, 1, 1}};
  EXPECT_FALSE(point.empty());
  EXPECT_TRUE(AabbsOverlap(point, unit));
  EXPECT_EQ(point.surface_area(), 0);
}

TEST(AabbTest, ExtendInflateContainArea) {
  Aabb box = Aabb::Empty();
  box.Extend(Vector3(1, 2, 3));
  EXPECT_FALSE(box.empty());
  EXPECT_EQ(box.min, Vector3(1, 2, 3));
  box.Extend(Aabb{{-1, 0, 0}, {0, 0, 4}});
  EXPECT_EQ(box.min, Vector3(-1, 0, 0));
  EXPECT_EQ(box.max, Vector3(1, 2, 4));
  EXPECT_EQ(box.size(), Vector3(2, 2, 4));
  EXPECT_EQ(box.center(), Vector3(0, 1, 2));
  EXPECT_DOUBLE_EQ(box.surface_area(), 2 * (4 + 8 + 8));
  const Aabb fat = box.Inflated(0.5);
  EXPECT_EQ(fat.min, Vector3(-1.5, -0.5, -0.5));
  EXPECT_TRUE(fat.Contains(box));
  EXPECT_FALSE(box.Contains(fat));
  EXPECT_TRUE(box.Contains(Vector3(1, 2, 4)));  // closed
  EXPECT_FALSE(box.Contains(Vector3(1, 2, std::nextafter(4.0, 5.0))));
  const Aabb of_triangle = Aabb::OfTriangle({{0, 0, 0}, {1, -1, 0}, {0, 2, 3}});
  EXPECT_EQ(of_triangle.min, Vector3(0, -1, 0));
  EXPECT_EQ(of_triangle.max, Vector3(1, 2, 3));
}

// ---- DynamicAabbTree ----

using PairList = std::vector<std::pair<int, int>>;

PairList Sorted(const std::vector<ProxyPair>& pairs) {
  PairList out;
  for (const ProxyPair& p : pairs) out.emplace_back(p.a, p.b);
  std::sort(out.begin(), out.end());
  return out;
}

// Brute force over the live proxies' own boxes.
PairList BruteForcePairs(const DynamicAabbTree& tree, const std::vector<int>& live) {
  PairList out;
  for (size_t i = 0; i < live.size(); ++i) {
    for (size_t j = i + 1; j < live.size(); ++j) {
      if (AabbsOverlap(tree.box(live[i]), tree.box(live[j]))) {
        out.emplace_back(std::min(live[i], live[j]), std::max(live[i], live[j]));
      }
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<int> BruteForceQuery(const DynamicAabbTree& tree, const std::vector<int>& live,
                                 const Aabb& box) {
  std::vector<int> out;
  for (int id : live) {
    if (AabbsOverlap(tree.box(id), box)) out.push_back(id);
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(DynamicAabbTreeTest, EmptyTree) {
  DynamicAabbTree tree(8, 0.1);
  std::vector<ProxyPair> pairs;
  std::vector<int> hits;
  tree.FindOverlappingPairs(&pairs);
  tree.Query({{0, 0, 0}, {1, 1, 1}}, &hits);
  EXPECT_TRUE(pairs.empty());
  EXPECT_TRUE(hits.empty());
  EXPECT_EQ(tree.height(), -1);
  EXPECT_TRUE(tree.CheckInvariants());
  EXPECT_FALSE(tree.Remove(0));
  EXPECT_FALSE(tree.Move(3, {{0, 0, 0}, {1, 1, 1}}));
}

// Boxes that share only a face, an edge or a corner are pairs; the fat boxes of
// nearby boxes overlap, but only the objects' own boxes decide.
TEST(DynamicAabbTreeTest, TouchingCountsAndFatBoxesDoNot) {
  DynamicAabbTree tree(8, 0.25);
  const int a = tree.Insert({{0, 0, 0}, {1, 1, 1}});
  const int b = tree.Insert({{1, 0, 0}, {2, 1, 1}});        // face with a
  const int c = tree.Insert({{2, 1, 1}, {3, 2, 2}});        // corner with b
  const int d = tree.Insert({{0, 1.125, 0}, {1, 2, 1}});    // 1/8 above a: fat boxes overlap
  std::vector<ProxyPair> pairs;
  tree.FindOverlappingPairs(&pairs);
  const PairList expected{{std::min(a, b), std::max(a, b)}, {std::min(b, c), std::max(b, c)}};
  EXPECT_EQ(Sorted(pairs), expected);
  std::vector<int> hits;
  tree.Query({{1, 1, 1}, {1, 1, 1}}, &hits);  // a corner point of a and b
  std::sort(hits.begin(), hits.end());
  EXPECT_EQ(hits, (std::vector<int>{a, b}));
  tree.Query({{2, 1, 1}, {2, 1, 1}}, &hits);  // the corner shared by b and c
  std::sort(hits.begin(), hits.end());
  EXPECT_EQ(hits, (std::vector<int>{b, c}));
  tree.Query(Aabb::Empty(), &hits);
  EXPECT_TRUE(hits.empty());
  (void)d;
  EXPECT_TRUE(tree.CheckInvariants());
}

// Small motions stay inside the fat box (no tree change); large ones reinsert.
TEST(DynamicAabbTreeTest, SmallMotionsNeedNoUpdate) {
  DynamicAabbTree tree(4, 0.1);
  const Aabb box{{0, 0, 0}, {1, 1, 1}};
  const int id = tree.Insert(box);
  tree.Insert({{5, 5, 5}, {6, 6, 6}});
  const Vector3 step(0.05, -0.05, 0.02);
  EXPECT_FALSE(tree.Move(id, {box.min + step, box.max + step}));
  EXPECT_EQ(tree.box(id).min, box.min + step);
  EXPECT_EQ(tree.fat_box(id).min, Vector3(box.min.array() - 0.1));
  const Vector3 jump(3, 0, 0);
  EXPECT_TRUE(tree.Move(id, {box.min + jump, box.max + jump}, jump));
  // Stretched ahead by twice the displacement.
  EXPECT_DOUBLE_EQ(tree.fat_box(id).max.x(), 4 + 0.1 + 6);
  EXPECT_DOUBLE_EQ(tree.fat_box(id).min.x(), 3 - 0.1);
  EXPECT_TRUE(tree.CheckInvariants());
}

// Inserting many boxes keeps the height rule (CheckInvariants) and the height within
// 1.81 log2(n) + 2; growth beyond the preallocated capacity still works.
TEST(DynamicAabbTreeTest, StaysBalancedAndGrows) {
  DynamicAabbTree tree(100, 0.01);
  // Sorted insertions along a line: the worst case for a naive tree.
  for (int i = 0; i < 300; ++i) {
    tree.Insert(MakeBox(Vector3(i, 0, 0), Vector3(0.4, 0.4, 0.4)));
    ASSERT_TRUE(tree.CheckInvariants()) << "after insert " << i;
  }
  EXPECT_EQ(tree.size(), 300);
  EXPECT_LE(tree.height(), 1.81 * std::log2(300) + 2);
  std::vector<ProxyPair> pairs;
  tree.FindOverlappingPairs(&pairs);
  EXPECT_TRUE(pairs.empty());
}

// The main check: many random steps of motion and churn against brute force.
TEST(DynamicAabbTreeTest, RandomStepsMatchBruteForce) {
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> coord(0, 20);
  std::uniform_real_distribution<double> half(0.05, 0.8);
  std::uniform_real_distribution<double> jitter(-0.08, 0.08);
  std::uniform_real_distribution<double> unit(0, 1);
  constexpr int kObjects = 400;
  const auto random_box = [&] {
    return MakeBox({coord(rng), coord(rng), coord(rng)}, {half(rng), half(rng), half(rng)});
  };
  DynamicAabbTree tree(kObjects, 0.1);
  std::vector<int> live;
  for (int i = 0; i < kObjects; ++i) {
    live.push_back(tree.Insert(random_box()));
  }
  std::vector<ProxyPair> pairs;
  pairs.reserve(20000);
  std::vector<int> hits;
  hits.reserve(kObjects);
  const ProxyPair* pairs_storage = pairs.data();
  const int* hits_storage = hits.data();
  int reinserted = 0;
  int total_pairs = 0;
  for (int step = 0; step < 200; ++step) {
    // Motion: all move a little; 3% jump far, with the displacement hint.
    for (int id : live) {
      const Aabb& old = tree.box(id);
      Vector3 d(jitter(rng), jitter(rng), jitter(rng));
      if (unit(rng) < 0.03) d = Vector3(coord(rng), coord(rng), coord(rng)) - old.center();
      reinserted += tree.Move(id, {old.min + d, old.max + d}, d);
    }
    // Churn: remove a few, insert a few (ids get reused).
    for (int k = 0; k < 5; ++k) {
      const size_t victim = static_cast<size_t>(unit(rng) * live.size()) % live.size();
      ASSERT_TRUE(tree.Remove(live[victim]));
      ASSERT_FALSE(tree.contains(live[victim]));
      live.erase(live.begin() + victim);
    }
    for (int k = 0; k < 5; ++k) {
      live.push_back(tree.Insert(random_box()));
    }
    ASSERT_TRUE(tree.CheckInvariants()) << "step " << step;
    ASSERT_EQ(tree.size(), static_cast<int>(live.size()));

    tree.FindOverlappingPairs(&pairs);
    const PairList found = Sorted(pairs);
    // Each pair once, a < b.
    for (const ProxyPair& p : pairs) ASSERT_LT(p.a, p.b);
    ASSERT_TRUE(std::adjacent_find(found.begin(), found.end()) == found.end());
    ASSERT_EQ(found, BruteForcePairs(tree, live)) << "step " << step;
    total_pairs += static_cast<int>(found.size());

    for (int q = 0; q < 10; ++q) {
      const Aabb query = MakeBox({coord(rng), coord(rng), coord(rng)},
                                 {2 * half(rng), 2 * half(rng), 2 * half(rng)});
      tree.Query(query, &hits);
      std::sort(hits.begin(), hits.end());
      ASSERT_EQ(hits, BruteForceQuery(tree, live, query));
    }
  }
  // The caller's vectors were reused, never reallocated.
  EXPECT_EQ(pairs.data(), pairs_storage);
  EXPECT_EQ(hits.data(), hits_storage);
  // Small motions mostly avoided reinsertion; the test saw real overlaps.
  EXPECT_LT(reinserted, 200 * kObjects / 2);
  EXPECT_GT(reinserted, 200 * kObjects * 3 / 100);
  EXPECT_GT(total_pairs, 200 * 30);
}

// Remove everything, then refill: ids are reused and the tree stays consistent.
TEST(DynamicAabbTreeTest, RemoveAllAndRefill) {
  DynamicAabbTree tree(16, 0.1);
  std::vector<int> ids;
  for (int i = 0; i < 16; ++i) {
    ids.push_back(tree.Insert(MakeBox(Vector3(i, 0, 0), Vector3(0.6, 0.5, 0.5))));
  }
  std::vector<ProxyPair> pairs;
  tree.FindOverlappingPairs(&pairs);
  EXPECT_EQ(pairs.size(), 15u);
  for (int id : ids) ASSERT_TRUE(tree.Remove(id));
  EXPECT_FALSE(tree.Remove(ids[0]));
  EXPECT_EQ(tree.size(), 0);
  EXPECT_TRUE(tree.CheckInvariants());
  for (int i = 0; i < 16; ++i) {
    const int id = tree.Insert(MakeBox(Vector3(0, i, 0), Vector3(0.5, 0.5, 0.5)));
    EXPECT_LT(id, 32);  // reused storage
  }
  tree.FindOverlappingPairs(&pairs);
  EXPECT_EQ(pairs.size(), 15u);
  EXPECT_TRUE(tree.CheckInvariants());
}

// Invalid ids are refused, not crashed on: internal nodes, free nodes, out of range.
TEST(DynamicAabbTreeTest, InvalidIdsAreRefused) {
  DynamicAabbTree tree(4, 0.1);
  const int a = tree.Insert({{0, 0, 0}, {1, 1, 1}});
  const int b = tree.Insert({{2, 0, 0}, {3, 1, 1}});
  for (int id : {-1, 1000, std::numeric_limits<int>::max()}) {
    EXPECT_FALSE(tree.contains(id));
    EXPECT_FALSE(tree.Remove(id));
    EXPECT_FALSE(tree.Move(id, {{0, 0, 0}, {1, 1, 1}}));
  }
  // Some node besides a and b is the internal root.
  for (int id = 0; id < 8; ++id) {
    if (id != a && id != b) {
      EXPECT_FALSE(tree.Remove(id));
    }
  }
  EXPECT_TRUE(tree.CheckInvariants());
}

// NaN boxes neither crash nor corrupt the structure; they overlap nothing.
TEST(DynamicAabbTreeTest, NonFiniteBoxesDoNotCrash) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  DynamicAabbTree tree(8, 0.1);
  const int good = tree.Insert({{0, 0, 0}, {1, 1, 1}});
  const int bad = tree.Insert({{nan, 0, 0}, {1, nan, 1}});
  tree.Insert({{-inf, -inf, -inf}, {inf, inf, inf}});
  const int overlapping = tree.Insert({{0.5, 0.5, 0.5}, {2, 2, 2}});
  tree.Move(bad, {{nan, nan, nan}, {nan, nan, nan}}, Vector3(nan, 0, 0));
  tree.Move(good, {{0, 0, 0}, {1, 1, 1}}, Vector3(inf, 0, 0));
  std::vector<ProxyPair> pairs;
  std::vector<int> hits;
  tree.FindOverlappingPairs(&pairs);
  tree.Query({{nan, 0, 0}, {1, 1, 1}}, &hits);
  EXPECT_TRUE(hits.empty());
  // The finite boxes still pair up (so the check on bad below is not vacuous).
  const PairList found = Sorted(pairs);
  const std::pair<int, int> finite_pair{std::min(good, overlapping), std::max(good, overlapping)};
  EXPECT_NE(std::find(found.begin(), found.end(), finite_pair), found.end());
  for (const ProxyPair& p : pairs) EXPECT_TRUE(p.a != bad && p.b != bad);
  EXPECT_TRUE(tree.Remove(bad));
  EXPECT_EQ(tree.size(), 3);
}

}  // namespace
}  // namespace hapticd::geometry
