// The scene's chunked object list against a plain vector of pointers, through random
// appends, replacements and erasures (across chunk boundaries), with copies (a
// snapshot's) taken along the way that must keep the objects they were made with while
// the original changes, and that share every chunk they have not seen changed.
#include "server/scene/object_list.h"

#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <string>
#include <vector>

namespace hapticd::scene {
namespace {

using Pointer = ObjectList::Pointer;

Pointer Named(int serial) {
  auto object = std::make_shared<SceneObject>();
  object->name = std::to_string(serial);
  object->name.insert(object->name.begin(), 'o');
  return object;
}

void ExpectSame(const ObjectList& list, const std::vector<Pointer>& want, const std::string& what) {
  ASSERT_EQ(list.size(), static_cast<int>(want.size())) << what;
  for (int i = 0; i < list.size(); ++i) ASSERT_EQ(list[i], want[i]) << what << ": object " << i;
}

TEST(ObjectList, MatchesAVectorAndItsCopiesKeepWhatTheyHeld) {
  std::mt19937_64 random(1205);
  ObjectList list;
  std::vector<Pointer> model;
  struct Copy {
    ObjectList list;
    std::vector<Pointer> model;
  };
  std::vector<Copy> copies;
  int serial = 0;
  for (int step = 0; step < 6000; ++step) {
    const int size = list.size();
    const int action = static_cast<int>(random() % 10);
    if (size == 0 || action < 5) {
      Pointer object = Named(serial++);
      list.PushBack(object);
      model.push_back(object);
    } else if (action < 8) {
      const int i = static_cast<int>(random() % size);
      Pointer object = Named(serial++);
      list.Writable(i) = object;
      model[i] = object;
    } else {
      const int i = static_cast<int>(random() % size);
      list.Erase(i);
      model.erase(model.begin() + i);
    }
    ExpectSame(list, model, "step " + std::to_string(step));
    if (step % 97 == 0) copies.push_back({list, model});
    if (HasFailure()) return;
  }
  EXPECT_GT(list.size(), 3 * ObjectList::kChunk);
  for (const Copy& copy : copies) ExpectSame(copy.list, copy.model, "a copy");
}

// A copy costs a pointer per chunk: what neither changes stays shared, and an entry
// written in one is not seen in the other.
TEST(ObjectList, CopiesShareUntilWritten) {
  ObjectList list;
  for (int i = 0; i < 5 * ObjectList::kChunk; ++i) list.PushBack(Named(i));
  ObjectList copy = list;
  const Pointer before = list[3];
  EXPECT_EQ(before.use_count(), 2);  // `before` and the one chunk both lists hold
  list.Writable(3) = Named(1000);
  EXPECT_EQ(copy[3], before);
  EXPECT_EQ(list[3]->name, "o1000");
  // the written chunk was copied (the old one is the copy's alone); the others are
  // still one chunk for both
  EXPECT_EQ(list[4], copy[4]);
  EXPECT_EQ(list[4].use_count(), 2);
  EXPECT_EQ(list[ObjectList::kChunk].use_count(), 1);
  // erasing shifts the list's later objects, never the copy's
  list.Erase(0);
  EXPECT_EQ(copy[0]->name, "o0");
  EXPECT_EQ(list[0]->name, "o1");
  EXPECT_EQ(list.size(), copy.size() - 1);
}

}  // namespace
}  // namespace hapticd::scene
