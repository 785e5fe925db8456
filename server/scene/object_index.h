#pragma once

// The broad phase over a scene's objects: which objects' boxes (SceneObject::bounds_W)
// overlap a query's box, at a cost that grows with the objects near it, not with the
// scene. Dynamic AABB trees (geometry::DynamicAabbTree) hold the bounded objects in
// three parts: the kinematic objects; the static objects added lately (at most
// kMaxRecent); and all other static objects. Objects without finite bounds (planes) are
// kept aside and always reported.
//
// The scene builder keeps one index and updates it with each edit; each snapshot holds
// a copy. A copy shares the parts (copy on write), so publishing a snapshot copies none
// of them, and the builder's next edit copies only the part it changes: moving the
// kinematic objects copies their small tree; adding a static object copies the small
// tree of recent ones, which joins the large one (one copy of it) every kMaxRecent adds.
// A kinematic move changes its tree only when the object leaves its fat box
// (kFatMargin). Read by any thread; ForEachNear never allocates.
//
// A caller that asks about nearly the same place again and again (an avatar, tick after
// tick) keeps a NearCache: the static objects (both static trees) within a margin of
// where it last asked. While its queries stay inside that region and a tree is the
// same, they test the few remembered objects instead of walking it, so a tick in a scene
// of 10,000 objects costs about what it costs in a scene of ten. The kinematic tree is
// always walked: it changes every few moves.

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "server/geometry/aabb.h"
#include "server/geometry/broad_phase.h"

namespace hapticd::scene {

// One caller's memory of the static trees around its last query (see above). Used by
// one thread at a time; holds no pointer into the index.
class NearCache {
 public:
  // The most objects remembered of a tree.
  static constexpr int kCapacity = 64;
  // How far (m) the remembered region reaches past the query's box: kMaxMargin (a hand
  // at 0.2 m/s leaves it every 800 ticks; each time it walks the tree with cold caches,
  // about 14 us among 10,000 objects, so this must be rarer than one tick in 1,000),
  // halved while the region holds more than kCapacity objects, down to kMinMargin (below
  // it nothing is remembered: the queries walk the tree); doubled again where it holds
  // under a quarter of that.
  static constexpr double kMaxMargin = 0.16;
  static constexpr double kMinMargin = 0.001;

 private:
  friend class ObjectIndex;
  struct Tree {
    uint64_t generation = 0;  // of the tree remembered; 0: nothing
    double margin = kMaxMargin;
    geometry::Aabb region = geometry::Aabb::Empty();
    int count = 0;
    std::array<int, kCapacity> proxies{};
    // their boxes, copied: a tick tests them in one run of memory instead of reaching
    // into the tree for each (a static tree's boxes change only with its generation)
    std::array<geometry::Aabb, kCapacity> boxes{};
  };
  Tree static_, recent_;
};

class ObjectIndex {
 public:
  // How far (m) a fat box reaches past its object's box: motions smaller than this
  // leave the tree alone.
  static constexpr double kFatMargin = 0.005;
  // Static objects added since the large tree was last copied: the most before they join it.
  static constexpr int kMaxRecent = 256;

  ObjectIndex();

  // Object indices are positions in the scene's object list. Insert appends: object
  // must be the number of objects indexed so far. kinematic: the object moves (it goes
  // to the kinematic tree).
  void Insert(int object, const geometry::Aabb& bounds, bool kinematic);
  // New bounds (or motion) for an object, after an update or a move; displacement is
  // its last motion, which stretches the fat box ahead of it.
  void Move(int object, const geometry::Aabb& bounds, bool kinematic,
            const geometry::Vector3& displacement = geometry::Vector3::Zero());
  // Removes an object; the objects after it move down one index, as in the list.
  void Erase(int object);

  int size() const { return static_cast<int>(entries_->size()); }

  // Calls visit(object) for every object whose box overlaps box (closed boxes), each
  // once, in no particular order; objects without finite bounds always. visit returns
  // false to end the walk.
  template <typename Visit>
  void ForEachNear(const geometry::Aabb& box, Visit visit) const {
    for (const int object : unbounded_) {
      if (!visit(object)) return;
    }
    for (const auto& part : parts_) {
      if (!Walk(*part, box, visit)) return;
    }
  }
  // The same, with the static trees' objects taken from cache where it remembers the
  // region (and remembering it first where it does not). Never allocates.
  template <typename Visit>
  void ForEachNear(const geometry::Aabb& box, NearCache& cache, Visit visit) const {
    for (const int object : unbounded_) {
      if (!visit(object)) return;
    }
    if (!Walk(*parts_[kKinematic], box, visit)) return;
    if (!ForEachRemembered(*parts_[kRecent], box, cache.recent_, visit)) return;
    ForEachRemembered(*parts_[kStatic], box, cache.static_, visit);
  }

 private:
  // One tree and the object each of its proxies (node indices) stands for.
  struct Part {
    geometry::DynamicAabbTree tree{/*capacity=*/16, kFatMargin};
    std::vector<int> object_of_proxy;
    // New with every change (never 0): a NearCache remembers the part by it.
    uint64_t generation = NextGeneration();
  };
  enum PartId : int { kStatic, kRecent, kKinematic, kNumParts };
  // Where an object is: its proxy in a part's tree, or aside (proxy -1).
  struct Entry {
    int proxy = -1;
    PartId part = kStatic;
  };

  static bool IsBounded(const geometry::Aabb& bounds);
  static uint64_t NextGeneration() {
    static std::atomic<uint64_t> last{0};
    return ++last;
  }
  static bool Contains(const geometry::Aabb& outer, const geometry::Aabb& inner) {
    return (outer.min.array() <= inner.min.array()).all() && (inner.max.array() <= outer.max.array()).all();
  }
  // Fills cache with part's objects within its margin of box (see NearCache); where more
  // are there than it holds, it is left remembering nothing.
  static void Remember(const Part& part, const geometry::Aabb& box, NearCache::Tree& cache);
  // ForEachNear's walk of one part's tree; false when a visit ended it.
  template <typename Visit>
  static bool Walk(const Part& part, const geometry::Aabb& box, Visit& visit) {
    bool going = true;
    part.tree.ForEachOverlap(box, [&](int proxy) { return going = visit(part.object_of_proxy[proxy]); });
    return going;
  }
  // The same of one static part, through cache.
  template <typename Visit>
  static bool ForEachRemembered(const Part& part, const geometry::Aabb& box, NearCache::Tree& cache, Visit& visit) {
    if (cache.generation != part.generation || !Contains(cache.region, box)) Remember(part, box, cache);
    if (cache.generation != part.generation) return Walk(part, box, visit);
    for (int k = 0; k < cache.count; ++k) {
      const int proxy = cache.proxies[k];
      if (geometry::AabbsOverlap(cache.boxes[k], box) && !visit(part.object_of_proxy[proxy])) return false;
    }
    return true;
  }
  // The part or the entries, to be changed: copied first when a copy of the index
  // shares them (only the builder's thread makes copies, so a count of one stays one).
  template <typename T>
  static T& Writable(std::shared_ptr<const T>& shared);
  Part& WritablePart(PartId id) {
    Part& part = Writable(parts_[id]);
    part.generation = NextGeneration();
    return part;
  }
  // Puts object (whose entry exists) in part's tree or aside; Detach takes it out again.
  void Attach(int object, const geometry::Aabb& bounds, PartId part);
  void Detach(int object);
  // The recent static objects join the large tree.
  void MergeRecent();

  std::shared_ptr<const Part> parts_[kNumParts];
  std::shared_ptr<const std::vector<Entry>> entries_;  // by object
  std::vector<int> unbounded_;
};

}  // namespace hapticd::scene
