#include "server/scene/snapshot_publisher.h"

#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace hapticd::scene {
namespace {

// "s<version>-<i>-".
std::string NamePrefix(uint64_t version, size_t i) {
  std::string name = "s";
  name += std::to_string(version);
  name += '-';
  name += std::to_string(i);
  name += '-';
  return name;
}

// A snapshot whose content encodes its version: version % 4 + 1 spheres, each named
// "s<version>-<i>" (heap strings, so a freed snapshot read by mistake trips ASan) with
// radius = version.
std::shared_ptr<const SceneSnapshot> MakeSnapshot(uint64_t version) {
  std::vector<SceneObject> objects(version % 4 + 1);
  for (size_t i = 0; i < objects.size(); ++i) {
    objects[i].name = NamePrefix(version, i) + "a-name-too-long-for-the-small-string-buffer";
    objects[i].shape = SphereShape{static_cast<double>(version)};
  }
  return std::make_shared<const SceneSnapshot>(std::move(objects), SceneSettings{}, version);
}

// True when every object of the snapshot says the snapshot's version.
bool IsConsistent(const SceneSnapshot& snapshot) {
  const uint64_t v = snapshot.version();
  if (snapshot.num_objects() != static_cast<int>(v % 4 + 1)) return false;
  for (int i = 0; i < snapshot.num_objects(); ++i) {
    const SceneObject& o = snapshot.object(i);
    if (std::get<SphereShape>(o.shape).radius != static_cast<double>(v)) return false;
    if (o.name.rfind(NamePrefix(v, static_cast<size_t>(i)), 0) != 0) return false;
  }
  return true;
}

std::string PublishError(SnapshotPublisher& publisher, std::shared_ptr<const SceneSnapshot> next) {
  try {
    publisher.Publish(std::move(next));
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(SnapshotPublisher, ReadersSeeTheCurrentSnapshot) {
  SnapshotPublisher publisher(MakeSnapshot(1), 2);
  const int reader = publisher.AddReader();
  ASSERT_EQ(reader, 0);
  EXPECT_EQ(publisher.Acquire(reader).version(), 1u);
  publisher.Release(reader);
  publisher.Publish(MakeSnapshot(2));
  EXPECT_EQ(publisher.current()->version(), 2u);
  const SceneSnapshot& seen = publisher.Acquire(reader);
  EXPECT_EQ(seen.version(), 2u);
  EXPECT_TRUE(IsConsistent(seen));
  publisher.Release(reader);
  // nobody held version 1 at the publish: freed at once
  EXPECT_EQ(publisher.num_retired(), 0);
}

TEST(SnapshotPublisher, AHeldSnapshotLivesUntilReleased) {
  auto first = MakeSnapshot(1);
  const std::weak_ptr<const SceneSnapshot> watch = first;
  SnapshotPublisher publisher(std::move(first), 3);
  const int holder = publisher.AddReader();
  const int other = publisher.AddReader();
  const SceneSnapshot& held = publisher.Acquire(holder);
  // many publishes while held: version 1 stays; the ones nobody holds go
  for (uint64_t v = 2; v <= 10; ++v) publisher.Publish(MakeSnapshot(v));
  EXPECT_FALSE(watch.expired());
  EXPECT_EQ(held.version(), 1u);
  EXPECT_TRUE(IsConsistent(held));
  // everything from version 1 up is pinned by the holder's version
  EXPECT_EQ(publisher.num_retired(), 9);
  // another reader comes and goes: it sees the newest
  EXPECT_EQ(publisher.Acquire(other).version(), 10u);
  publisher.Release(other);
  // released: the next publish frees everything retired
  publisher.Release(holder);
  EXPECT_FALSE(watch.expired());
  publisher.Publish(MakeSnapshot(11));
  EXPECT_TRUE(watch.expired());
  EXPECT_EQ(publisher.num_retired(), 0);
}

TEST(SnapshotPublisher, OnlyOlderSnapshotsThanTheOldestHeldAreFreed) {
  SnapshotPublisher publisher(MakeSnapshot(1), 2);
  const int reader = publisher.AddReader();
  publisher.Publish(MakeSnapshot(2));
  publisher.Publish(MakeSnapshot(3));
  EXPECT_EQ(publisher.Acquire(reader).version(), 3u);
  publisher.Publish(MakeSnapshot(4));
  publisher.Publish(MakeSnapshot(5));
  // 3 is held; 4 was retired after 3 and is not older than it: kept too
  EXPECT_EQ(publisher.num_retired(), 2);
  publisher.Release(reader);
  publisher.Publish(MakeSnapshot(6));
  EXPECT_EQ(publisher.num_retired(), 0);
}

TEST(SnapshotPublisher, RemovingABusyReaderFreesWhatItHeld) {
  SnapshotPublisher publisher(MakeSnapshot(1), 1);
  const int reader = publisher.AddReader();
  publisher.Acquire(reader);
  publisher.Publish(MakeSnapshot(2));
  EXPECT_EQ(publisher.num_retired(), 1);
  publisher.RemoveReader(reader);
  EXPECT_EQ(publisher.num_retired(), 0);
}

TEST(SnapshotPublisher, ReaderSlotsAreFixed) {
  SnapshotPublisher publisher(MakeSnapshot(1), 3);
  EXPECT_EQ(publisher.AddReader(), 0);
  EXPECT_EQ(publisher.AddReader(), 1);
  EXPECT_EQ(publisher.AddReader(), 2);
  EXPECT_EQ(publisher.AddReader(), -1);
  publisher.RemoveReader(1);
  EXPECT_EQ(publisher.AddReader(), 1);
  EXPECT_EQ(publisher.AddReader(), -1);
  EXPECT_THROW(publisher.RemoveReader(3), std::invalid_argument);
  EXPECT_THROW(publisher.RemoveReader(-1), std::invalid_argument);
  SnapshotPublisher none(MakeSnapshot(1), 0);
  EXPECT_EQ(none.AddReader(), -1);
}

TEST(SnapshotPublisher, VersionsMustGrow) {
  EXPECT_THROW(SnapshotPublisher(nullptr, 1), std::invalid_argument);
  EXPECT_THROW(SnapshotPublisher(MakeSnapshot(0), 1), std::invalid_argument);
  EXPECT_THROW(SnapshotPublisher(MakeSnapshot(1), -1), std::invalid_argument);
  SnapshotPublisher publisher(MakeSnapshot(5), 1);
  EXPECT_EQ(PublishError(publisher, MakeSnapshot(5)),
            "snapshot version 5 must exceed the current version 5");
  EXPECT_EQ(PublishError(publisher, MakeSnapshot(3)),
            "snapshot version 3 must exceed the current version 5");
  EXPECT_EQ(PublishError(publisher, nullptr), "cannot publish a null snapshot");
  // a refused publish changes nothing
  EXPECT_EQ(publisher.current()->version(), 5u);
  EXPECT_EQ(PublishError(publisher, MakeSnapshot(6)), "");
  EXPECT_EQ(publisher.current()->version(), 6u);
}

// Two real-time readers tick against a writer publishing thousands of snapshots. Each
// tick reads every object of its snapshot (under ASan: a read of a freed snapshot
// fails the run) and checks the snapshot is whole and never older than the last one.
TEST(SnapshotPublisher, StressReadersAgainstAWriter) {
  constexpr uint64_t kPublishes = 5000;
  SnapshotPublisher publisher(MakeSnapshot(1), 4);
  std::atomic<bool> done{false};
  std::atomic<int> inconsistent{0};
  std::atomic<int> went_back{0};
  std::atomic<long> ticks{0};
  std::atomic<int> started{0};
  auto reader_loop = [&] {
    const int reader = publisher.AddReader();
    started.fetch_add(1);
    ASSERT_GE(reader, 0);
    uint64_t last = 0;
    while (!done.load(std::memory_order_relaxed)) {
      const SceneSnapshot& snapshot = publisher.Acquire(reader);
      if (!IsConsistent(snapshot)) inconsistent.fetch_add(1);
      if (snapshot.version() < last) went_back.fetch_add(1);
      last = snapshot.version();
      publisher.Release(reader);
      ticks.fetch_add(1, std::memory_order_relaxed);
    }
    publisher.RemoveReader(reader);
  };
  std::thread a(reader_loop), b(reader_loop);
  while (started.load() < 2) std::this_thread::yield();
  for (uint64_t v = 2; v <= kPublishes; ++v) {
    publisher.Publish(MakeSnapshot(v));
    // let the readers in now and then on a busy machine
    if (v % 64 == 0) std::this_thread::yield();
  }
  done.store(true);
  a.join();
  b.join();
  EXPECT_EQ(inconsistent.load(), 0);
  EXPECT_EQ(went_back.load(), 0);
  EXPECT_GT(ticks.load(), 0);
  // readers gone: one more publish frees everything retired
  publisher.Publish(MakeSnapshot(kPublishes + 1));
  EXPECT_EQ(publisher.num_retired(), 0);
  EXPECT_EQ(publisher.current()->version(), kPublishes + 1);
}

}  // namespace
}  // namespace hapticd::scene
