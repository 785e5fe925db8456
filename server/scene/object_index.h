#pragma once

// The broad phase over a scene's objects: which objects' boxes (SceneObject::bounds_W)
// overlap a query's box, at a cost that grows with the objects near it, not with the
// scene. A dynamic AABB tree (geometry::DynamicAabbTree) holds the bounded objects;
// objects without finite bounds (planes) are kept aside and always reported.
//
// The scene builder keeps one index and updates it with each edit: a kinematic move
// changes the tree only when the object leaves its fat box (kFatMargin), so moving a
// hundred objects a millisecond does not rebuild anything. Each snapshot holds a copy,
// read by any thread; ForEachNear never allocates.

#include <vector>

#include "server/geometry/aabb.h"
#include "server/geometry/broad_phase.h"

namespace hapticd::scene {

class ObjectIndex {
 public:
  // How far (m) a fat box reaches past its object's box: motions smaller than this
  // leave the tree alone.
  static constexpr double kFatMargin = 0.005;

  ObjectIndex();

  // Object indices are positions in the scene's object list. Insert appends: object
  // must be the number of objects indexed so far.
  void Insert(int object, const geometry::Aabb& bounds);
  // New bounds for an object (after an update or a move); displacement is its last
  // motion, which stretches the fat box ahead of it.
  void Move(int object, const geometry::Aabb& bounds,
            const geometry::Vector3& displacement = geometry::Vector3::Zero());
  // Removes an object; the objects after it move down one index, as in the list.
  void Erase(int object);

  int size() const { return static_cast<int>(proxy_of_object_.size()); }

  // Calls visit(object) for every object whose box overlaps box (closed boxes), each
  // once, in no particular order; objects without finite bounds always. visit returns
  // false to end the walk.
  template <typename Visit>
  void ForEachNear(const geometry::Aabb& box, Visit visit) const {
    for (const int object : unbounded_) {
      if (!visit(object)) return;
    }
    tree_.ForEachOverlap(box, [&](int proxy) { return visit(object_of_proxy_[proxy]); });
  }

 private:
  static bool IsBounded(const geometry::Aabb& bounds);
  // Puts object (whose proxy_of_object_ entry exists) in the tree or aside; Detach takes
  // it out of either.
  void Attach(int object, const geometry::Aabb& bounds);
  void Detach(int object);

  geometry::DynamicAabbTree tree_;
  // object -> its proxy in tree_, or -1 when it is in unbounded_
  std::vector<int> proxy_of_object_;
  // proxy (a node index of tree_) -> object
  std::vector<int> object_of_proxy_;
  std::vector<int> unbounded_;
};

}  // namespace hapticd::scene
