#include "server/scene/object_index.h"

#include <algorithm>

namespace hapticd::scene {

ObjectIndex::ObjectIndex() : tree_(/*capacity=*/16, kFatMargin) {}

bool ObjectIndex::IsBounded(const geometry::Aabb& bounds) {
  return !bounds.empty() && bounds.min.allFinite() && bounds.max.allFinite();
}

void ObjectIndex::Insert(int object, const geometry::Aabb& bounds) {
  proxy_of_object_.push_back(-1);
  Attach(object, bounds);
}

void ObjectIndex::Move(int object, const geometry::Aabb& bounds, const geometry::Vector3& displacement) {
  const int proxy = proxy_of_object_[object];
  if (proxy >= 0 && IsBounded(bounds)) {
    tree_.Move(proxy, bounds, displacement);
    return;
  }
  // between bounded and unbounded (an update that changed the shape): out, then in
  Detach(object);
  Attach(object, bounds);
}

void ObjectIndex::Attach(int object, const geometry::Aabb& bounds) {
  if (!IsBounded(bounds)) {
    proxy_of_object_[object] = -1;
    unbounded_.push_back(object);
    return;
  }
  const int proxy = tree_.Insert(bounds);
  proxy_of_object_[object] = proxy;
  if (proxy >= static_cast<int>(object_of_proxy_.size())) object_of_proxy_.resize(proxy + 1, -1);
  object_of_proxy_[proxy] = object;
}

void ObjectIndex::Detach(int object) {
  const int proxy = proxy_of_object_[object];
  if (proxy >= 0) {
    tree_.Remove(proxy);
    object_of_proxy_[proxy] = -1;
  } else {
    std::erase(unbounded_, object);
  }
}

void ObjectIndex::Erase(int object) {
  Detach(object);
  proxy_of_object_.erase(proxy_of_object_.begin() + object);
  // the objects after it move down one index
  for (int& o : object_of_proxy_) {
    if (o > object) --o;
  }
  for (int& o : unbounded_) {
    if (o > object) --o;
  }
}

}  // namespace hapticd::scene
