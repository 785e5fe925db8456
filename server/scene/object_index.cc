#include "server/scene/object_index.h"

#include <algorithm>

namespace hapticd::scene {

ObjectIndex::ObjectIndex()
    : parts_{std::make_shared<Part>(), std::make_shared<Part>(), std::make_shared<Part>()},
      entries_(std::make_shared<std::vector<Entry>>()) {}

bool ObjectIndex::IsBounded(const geometry::Aabb& bounds) {
  return !bounds.empty() && bounds.min.allFinite() && bounds.max.allFinite();
}

void ObjectIndex::Remember(const Part& part, const geometry::Aabb& box, NearCache::Tree& cache) {
  for (; cache.margin >= NearCache::kMinMargin; cache.margin /= 2) {
    cache.generation = part.generation;
    cache.region = box.Inflated(cache.margin);
    cache.count = 0;
    part.tree.ForEachOverlap(cache.region, [&](int proxy) {
      if (cache.count == NearCache::kCapacity) return false;
      cache.boxes[cache.count] = part.tree.box(proxy);
      cache.proxies[cache.count++] = proxy;
      return true;
    });
    // a full cache may have left some out: a smaller region
    if (cache.count < NearCache::kCapacity) {
      if (cache.count < NearCache::kCapacity / 4) cache.margin = std::min(2 * cache.margin, NearCache::kMaxMargin);
      return;
    }
  }
  // too many even within kMinMargin: remember nothing (the next query tries that margin
  // again, and widens it once the objects thin out)
  cache.generation = 0;
  cache.margin = NearCache::kMinMargin;
}

template <typename T>
T& ObjectIndex::Writable(std::shared_ptr<const T>& shared) {
  if (shared.use_count() > 1) shared = std::make_shared<T>(*shared);
  // every part and entry list is made non-const (make_shared<T>)
  return const_cast<T&>(*shared);
}

void ObjectIndex::Insert(int object, const geometry::Aabb& bounds, bool kinematic) {
  Writable(entries_).push_back({});
  if (!kinematic && parts_[kRecent]->tree.size() >= kMaxRecent) MergeRecent();
  Attach(object, bounds, kinematic ? kKinematic : kRecent);
}

void ObjectIndex::Move(int object, const geometry::Aabb& bounds, bool kinematic,
                       const geometry::Vector3& displacement) {
  const Entry entry = (*entries_)[object];
  if (entry.proxy >= 0 && (entry.part == kKinematic) == kinematic && IsBounded(bounds)) {
    WritablePart(entry.part).tree.Move(entry.proxy, bounds, displacement);
    return;
  }
  // to the other kind, or between bounded and unbounded (an update that changed the
  // shape or the motion): out, then in
  Detach(object);
  Attach(object, bounds, kinematic ? kKinematic : kRecent);
}

void ObjectIndex::Attach(int object, const geometry::Aabb& bounds, PartId part_id) {
  Entry& entry = Writable(entries_)[object];
  entry.part = part_id;
  if (!IsBounded(bounds)) {
    entry.proxy = -1;
    unbounded_.push_back(object);
    return;
  }
  Part& part = WritablePart(part_id);
  entry.proxy = part.tree.Insert(bounds);
  if (entry.proxy >= static_cast<int>(part.object_of_proxy.size())) part.object_of_proxy.resize(entry.proxy + 1, -1);
  part.object_of_proxy[entry.proxy] = object;
}

void ObjectIndex::Detach(int object) {
  const Entry entry = (*entries_)[object];
  if (entry.proxy >= 0) {
    Part& part = WritablePart(entry.part);
    part.tree.Remove(entry.proxy);
    part.object_of_proxy[entry.proxy] = -1;
  } else {
    std::erase(unbounded_, object);
  }
}

void ObjectIndex::MergeRecent() {
  const std::shared_ptr<const Part> recent = std::move(parts_[kRecent]);
  parts_[kRecent] = std::make_shared<Part>();
  for (int proxy = 0; proxy < static_cast<int>(recent->object_of_proxy.size()); ++proxy) {
    const int object = recent->object_of_proxy[proxy];
    if (object >= 0) Attach(object, recent->tree.box(proxy), kStatic);
  }
}

void ObjectIndex::Erase(int object) {
  Detach(object);
  std::vector<Entry>& entries = Writable(entries_);
  entries.erase(entries.begin() + object);
  // the objects after it move down one index
  for (const PartId id : {kStatic, kRecent, kKinematic}) {
    for (int& o : WritablePart(id).object_of_proxy) {
      if (o > object) --o;
    }
  }
  for (int& o : unbounded_) {
    if (o > object) --o;
  }
}

}  // namespace hapticd::scene
