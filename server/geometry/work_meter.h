#pragma once

// A bound on the work of one real-time tick. Every session renders on the one real-time
// thread, and a tick can meet a pathological spot of a scene (a stack of large
// overlapping triangles that no BVH can split, thousands of objects within reach, a
// hull of a million faces): left unbounded, one such tick would delay every other
// session's. So the queries charge their work to their thread's meter, one unit per BVH
// node opened, primitive tested or object visited, and per eight hull vertices or faces
// examined, and stop early once the budget is spent. Their answers are then
// incomplete: the caller that started the meter (RenderSession::Tick) throws the tick's
// result away, counts an overrun and sends the last safe force.
//
// Units, not time: the bound is the same on every machine and in every test, and a unit
// costs a few tens of nanoseconds here (bench/results/tick_isolation.md measures it).
// A thread with no meter running is unmetered. Embree's own node visits are not seen;
// its callbacks (one per candidate primitive) are charged, and once the budget is spent
// they cut the query short (a ray's tfar to -inf, a point query's radius to 0).

#include <cstdint>

namespace hapticd::geometry {

class WorkMeter {
 public:
  // Meters this thread's queries until the meter goes out of scope: budget units. A
  // meter inside another charges what it used to the outer one when it ends.
  explicit WorkMeter(int64_t budget) : budget_(budget), saved_(left_) { left_ = budget; }
  ~WorkMeter() { left_ = saved_ - used(); }
  WorkMeter(const WorkMeter&) = delete;
  WorkMeter& operator=(const WorkMeter&) = delete;

  bool exhausted() const { return left_ < 0; }
  // Units charged so far (past the budget when exhausted).
  int64_t used() const { return budget_ - left_; }

  // Called by the queries: charges units to this thread's meter; false once its budget
  // is spent (the query should stop).
  static bool Charge(int64_t units) { return (left_ -= units) >= 0; }
  static bool Exhausted() { return left_ < 0; }

 private:
  // What an unmetered thread has left: more than it can spend (2^62 units).
  static constexpr int64_t kUnmetered = int64_t{1} << 62;
  static inline thread_local int64_t left_ = kUnmetered;
  int64_t budget_;
  int64_t saved_;
};

}  // namespace hapticd::geometry
