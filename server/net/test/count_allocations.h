#pragma once
// Replaces the global operator new of the one test program that includes this header
// (include it in exactly one of its files), so a test can show that a real-time path
// makes no heap allocation: AllocationCount() before and after must agree. Where other
// threads allocate meanwhile (a builder thread), ThreadAllocationCount() and
// ThreadFreeCount() count the calling thread's alone.
#include <atomic>
#include <cstdlib>
#include <new>

namespace hapticd::testing {

inline std::atomic<long>& AllocationCounter() {
  static std::atomic<long> count{0};
  return count;
}

// Heap allocations made through operator new so far, by any thread.
inline long AllocationCount() { return AllocationCounter().load(std::memory_order_relaxed); }

// The calling thread's allocations and frees (operator delete of a non-null pointer) so far.
inline long& ThreadAllocationCounter() {
  thread_local long count = 0;
  return count;
}
inline long& ThreadFreeCounter() {
  thread_local long count = 0;
  return count;
}
inline long ThreadAllocationCount() { return ThreadAllocationCounter(); }
inline long ThreadFreeCount() { return ThreadFreeCounter(); }

}  // namespace hapticd::testing

// GCC pairs the builtin meaning of new with this free() and warns of a mismatch; here
// both sides are malloc/free by construction.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void* operator new(std::size_t size) {
  hapticd::testing::AllocationCounter().fetch_add(1, std::memory_order_relaxed);
  ++hapticd::testing::ThreadAllocationCounter();
  if (void* p = std::malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
  if (p != nullptr) ++hapticd::testing::ThreadFreeCounter();
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  if (p != nullptr) ++hapticd::testing::ThreadFreeCounter();
  std::free(p);
}
#pragma GCC diagnostic pop
