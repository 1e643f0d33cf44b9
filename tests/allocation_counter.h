#pragma once
// Counts every operator new of the test program while an AllocationCounter lives, from any thread
// (new[] and the nothrow forms go through these in libstdc++), with the largest size asked for:
// for tests that hold code to "allocates nothing". Replaces the global operator new, so include it
// in one file of a test binary only.

#include <atomic>
#include <cstdlib>
#include <new>

namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};
std::atomic<std::size_t> g_largest{0};
}  // namespace

void* operator new(std::size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) {
    g_allocations.fetch_add(1, std::memory_order_relaxed);
    std::size_t largest = g_largest.load(std::memory_order_relaxed);
    while (size > largest && !g_largest.compare_exchange_weak(largest, size)) {
    }
  }
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
// Not inlined, so that GCC sees new paired with delete and not with free (-Wmismatched-new-delete).
__attribute__((noinline)) void operator delete(void* p) noexcept { std::free(p); }
__attribute__((noinline)) void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace occmap::testing {

// Counts the allocations made while it lives.
class AllocationCounter {
 public:
  AllocationCounter() {
    g_allocations = 0;
    g_largest = 0;
    g_counting = true;
  }
  ~AllocationCounter() { g_counting = false; }
  long allocations() const { return g_allocations.load(); }
  std::size_t largest() const { return g_largest.load(); }
};

}  // namespace occmap::testing
