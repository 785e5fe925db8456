// The scene's broad phase against a scan of every box, through random inserts, moves
// (within the fat margin and beyond it), changes between static and kinematic and
// between bounded and unbounded, and erasures; copies (a snapshot's) that keep
// answering for the scene they were made from while the original changes; and a
// caller's cache of the static tree asked through all of it.
#include "server/scene/object_index.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace hapticd::scene {
namespace {

using geometry::Aabb;
using geometry::Vector3;

constexpr double kInf = std::numeric_limits<double>::infinity();

struct Model {
  std::vector<Aabb> boxes;  // by object
};

std::vector<int> Scan(const Model& model, const Aabb& query) {
  std::vector<int> found;
  for (int i = 0; i < static_cast<int>(model.boxes.size()); ++i) {
    const Aabb& box = model.boxes[i];
    const bool bounded = box.min.allFinite() && box.max.allFinite();
    if (!bounded || geometry::AabbsOverlap(box, query)) found.push_back(i);
  }
  return found;
}

std::vector<int> Near(const ObjectIndex& index, const Aabb& query) {
  std::vector<int> found;
  index.ForEachNear(query, [&](int i) {
    found.push_back(i);
    return true;
  });
  std::sort(found.begin(), found.end());
  return found;
}

std::vector<int> Near(const ObjectIndex& index, const Aabb& query, NearCache& cache) {
  std::vector<int> found;
  index.ForEachNear(query, cache, [&](int i) {
    found.push_back(i);
    return true;
  });
  std::sort(found.begin(), found.end());
  return found;
}

class Random {
 public:
  explicit Random(uint64_t seed) : engine_(seed) {}
  double Uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(engine_); }
  int Int(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(engine_); }
  Vector3 Point() { return {Uniform(-1, 1), Uniform(-1, 1), Uniform(-1, 1)}; }
  Aabb Box() {
    // one in twenty unbounded (a plane's half-space)
    if (Int(0, 19) == 0) return {Vector3::Constant(-kInf), Vector3(kInf, kInf, Uniform(-1, 1))};
    const Vector3 c = Point();
    const Vector3 h(Uniform(0.001, 0.05), Uniform(0.001, 0.05), Uniform(0.001, 0.05));
    return {c - h, c + h};
  }

 private:
  std::mt19937_64 engine_;
};

TEST(ObjectIndex, AnswersAsAScanThroughEveryEdit) {
  Random random(7);
  ObjectIndex index;
  Model model;
  std::vector<bool> kinematic;
  std::vector<std::pair<ObjectIndex, Model>> copies;
  int found = 0;
  for (int step = 0; step < 4000; ++step) {
    const int n = static_cast<int>(model.boxes.size());
    const int op = n < 50 ? 0 : random.Int(0, 9);
    if (op <= 3) {
      const bool moving = random.Int(0, 4) == 0;
      model.boxes.push_back(random.Box());
      kinematic.push_back(moving);
      index.Insert(n, model.boxes.back(), moving);
    } else if (op <= 7) {
      // a small motion (inside the fat box) or a jump; sometimes a new motion or shape
      const int i = random.Int(0, n - 1);
      Aabb& box = model.boxes[i];
      if (op == 7) {
        box = random.Box();
        kinematic[i] = random.Int(0, 1) == 0;
      } else if (box.min.allFinite() && box.max.allFinite()) {
        const Vector3 d = (op == 4 ? 0.001 : 0.2) * random.Point();
        box = {box.min + d, box.max + d};
      }
      index.Move(i, box, kinematic[i]);
    } else {
      const int i = random.Int(0, n - 1);
      model.boxes.erase(model.boxes.begin() + i);
      kinematic.erase(kinematic.begin() + i);
      index.Erase(i);
    }
    ASSERT_EQ(index.size(), static_cast<int>(model.boxes.size()));
    if (step % 200 == 0) copies.emplace_back(index, model);
    const Vector3 c = random.Point();
    const Aabb query{c - Vector3::Constant(0.1), c + Vector3::Constant(0.1)};
    const std::vector<int> want = Scan(model, query);
    ASSERT_EQ(Near(index, query), want) << "step " << step;
    found += static_cast<int>(want.size());
  }
  EXPECT_GT(found, 4000);
  // every copy still answers for the objects it was made from
  for (const auto& [copy, then] : copies) {
    for (int q = 0; q < 20; ++q) {
      const Vector3 c = random.Point();
      const Aabb query{c - Vector3::Constant(0.2), c + Vector3::Constant(0.2)};
      EXPECT_EQ(Near(copy, query), Scan(then, query));
    }
  }
}

TEST(ObjectIndex, ACachedWalkAnswersAsAScanThroughEveryEdit) {
  // an avatar's queries: a small box drifting a little each step, now and then jumping,
  // while objects are added, moved and erased, and copies of the index are asked with
  // the same cache (a new snapshot each tick)
  Random random(8);
  ObjectIndex index;
  Model model;
  std::vector<bool> kinematic;
  NearCache cache;
  Vector3 avatar = Vector3::Zero();
  int found = 0;
  for (int i = 0; i < 600; ++i) {
    model.boxes.push_back(random.Box());
    kinematic.push_back(random.Int(0, 9) == 0);
    index.Insert(i, model.boxes.back(), kinematic.back());
  }
  for (int step = 0; step < 6000; ++step) {
    const int n = static_cast<int>(model.boxes.size());
    const int op = random.Int(0, 19);
    // edits land where the cache looks half the time: an object near the avatar, or a
    // new box there
    const std::vector<int> around = Scan(model, {avatar - Vector3::Constant(0.1), avatar + Vector3::Constant(0.1)});
    const int i = around.empty() || random.Int(0, 1) == 0 ? random.Int(0, n - 1)
                                                          : around[random.Int(0, static_cast<int>(around.size()) - 1)];
    const Aabb box = random.Int(0, 1) == 0 ? random.Box() : Aabb{avatar - Vector3::Constant(0.01), avatar};
    if (op == 0) {
      model.boxes.push_back(box);
      kinematic.push_back(random.Int(0, 4) == 0);
      index.Insert(n, model.boxes.back(), kinematic.back());
    } else if (op <= 2) {
      if (op == 2) model.boxes[i] = box;
      index.Move(i, model.boxes[i], kinematic[i]);
    } else if (op == 3) {
      model.boxes.erase(model.boxes.begin() + i);
      kinematic.erase(kinematic.begin() + i);
      index.Erase(i);
    }
    avatar += (random.Int(0, 99) == 0 ? 0.5 : 0.002) * random.Point();
    avatar = avatar.cwiseMax(Vector3::Constant(-1)).cwiseMin(Vector3::Constant(1));
    const double size = random.Uniform(0, 0.06);
    const Aabb query{avatar - Vector3::Constant(size), avatar + Vector3::Constant(size)};
    const std::vector<int> want = Scan(model, query);
    const ObjectIndex snapshot = index;
    ASSERT_EQ(Near(snapshot, query, cache), want) << "step " << step;
    found += static_cast<int>(want.size());
  }
  EXPECT_GT(found, 6000);
  // a query no cache can hold (every object) and then a small one again
  const Aabb everything{Vector3::Constant(-2), Vector3::Constant(2)};
  EXPECT_EQ(Near(index, everything, cache), Scan(model, everything));
  const Aabb small{Vector3::Constant(-0.05), Vector3::Constant(0.05)};
  EXPECT_EQ(Near(index, small, cache), Scan(model, small));
  // an empty box finds only the unbounded objects
  EXPECT_EQ(Near(index, Aabb::Empty(), cache), Scan(model, Aabb::Empty()));
}

TEST(ObjectIndex, ACachedWalkAnswersAsAScanWhereObjectsCrowd) {
  // a row of 400 boxes 0.1 mm apart (more than a cache holds within any margin), sparse
  // boxes around it, and an avatar walking from the sparse part into the row and out
  Random random(9);
  ObjectIndex index;
  Model model;
  for (int i = 0; i < 400; ++i) {
    const Vector3 c(0.0001 * i, 0, 0);
    model.boxes.push_back({c - Vector3::Constant(0.00004), c + Vector3::Constant(0.00004)});
  }
  for (int i = 0; i < 200; ++i) model.boxes.push_back(random.Box());
  for (int i = 0; i < static_cast<int>(model.boxes.size()); ++i) index.Insert(i, model.boxes[i], false);
  NearCache cache;
  for (int step = 0; step < 3000; ++step) {
    const double s = step / 3000.0;
    const Vector3 avatar(-0.3 + s, 0.05 * std::sin(20 * s), 0);
    const Aabb query{avatar - Vector3::Constant(0.002), avatar + Vector3::Constant(0.002)};
    ASSERT_EQ(Near(index, query, cache), Scan(model, query)) << "step " << step;
  }
}

TEST(ObjectIndex, AVisitThatReturnsFalseEndsTheWalk) {
  ObjectIndex index;
  for (int i = 0; i < 10; ++i) index.Insert(i, {Vector3::Zero(), Vector3::Ones()}, i % 2 == 1);
  int visits = 0;
  index.ForEachNear({Vector3::Zero(), Vector3::Ones()}, [&](int) { return ++visits < 3; });
  EXPECT_EQ(visits, 3);
  NearCache cache;
  visits = 0;
  index.ForEachNear({Vector3::Zero(), Vector3::Ones()}, cache, [&](int) { return ++visits < 3; });
  EXPECT_EQ(visits, 3);
}

}  // namespace
}  // namespace hapticd::scene
