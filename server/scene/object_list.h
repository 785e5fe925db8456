#pragma once

// A scene's objects in order, shared between the builder and the snapshots it publishes
// in chunks of kChunk: a snapshot copies one pointer per chunk, not one per object
// (10,000 objects: 313 reference counts a publish instead of 10,000), and an edit copies
// a chunk only where a snapshot still holds it. Each object is shared too, so an edit
// copies the object it changes, not its chunk's neighbours.
//
// Entries point to non-const SceneObjects and chunks are made non-const
// (SceneBuilder's copy-on-write, and Writable below, rely on it). Copies are read from
// any thread; only one thread (the builder's) changes a list, and only that thread makes
// copies, so a chunk held once stays held once while it is changed.

#include <array>
#include <memory>
#include <vector>

#include "server/scene/scene_object.h"

namespace hapticd::scene {

class ObjectList {
 public:
  using Pointer = std::shared_ptr<const SceneObject>;
  static constexpr int kChunk = 32;

  int size() const { return size_; }
  // Object i (0 <= i < size()).
  const Pointer& operator[](int i) const { return (*chunks_[i / kChunk])[i % kChunk]; }

  // Object i's entry, to be replaced: its chunk copied first where another list shares it.
  Pointer& Writable(int i) {
    std::shared_ptr<const Chunk>& chunk = chunks_[i / kChunk];
    if (chunk.use_count() > 1) chunk = std::make_shared<Chunk>(*chunk);
    return const_cast<Chunk&>(*chunk)[i % kChunk];
  }
  void PushBack(Pointer object) {
    if (size_ % kChunk == 0) chunks_.push_back(std::make_shared<Chunk>());
    Writable(size_++) = std::move(object);
  }
  // Removes object i; the objects after it move down one.
  void Erase(int i) {
    for (; i + 1 < size_; ++i) Writable(i) = (*this)[i + 1];
    Writable(--size_).reset();
    if (size_ % kChunk == 0) chunks_.pop_back();
  }

 private:
  using Chunk = std::array<Pointer, kChunk>;
  std::vector<std::shared_ptr<const Chunk>> chunks_;
  int size_ = 0;
};

}  // namespace hapticd::scene
