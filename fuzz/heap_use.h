#pragma once
// The bytes the heap hands out while a piece of code runs, for the targets that check what a
// decoder allocates (camera_preview, camera_preview_request): a hostile message must not make a
// client allocate more than the sizes it declares within their bounds, and some decoders promise
// to allocate nothing at all. Counted through the sanitizer allocator's malloc hook, which sees
// every allocation (operator new, malloc, zstd's contexts) of every thread: only where clang's
// AddressSanitizer runs (the fuzz build). Elsewhere (the plain build's fuzz_regression_test)
// nothing is counted and `counted()` says so.
#include <cstddef>

#if defined(__has_feature)
#if __has_feature(address_sanitizer) && __has_include(<sanitizer/allocator_interface.h>)
#include <sanitizer/allocator_interface.h>
#define OCCMAP_FUZZ_COUNTS_HEAP 1
#endif
#endif

namespace occmap::fuzz {

class HeapUse {
 public:
  // Counts from now until the object goes. One at a time (the targets are single-threaded).
  HeapUse() {
#ifdef OCCMAP_FUZZ_COUNTS_HEAP
    static const bool installed =
        __sanitizer_install_malloc_and_free_hooks(&onMalloc, &onFree) != 0;
    counting_ = installed;
    state().allocations = 0;
    state().bytes = 0;
    state().on = counting_;
#endif
  }
  ~HeapUse() { state().on = false; }
  HeapUse(const HeapUse&) = delete;
  HeapUse& operator=(const HeapUse&) = delete;

  // Whether allocations are counted at all in this build.
  bool counted() const { return counting_; }
  // Allocations and their bytes so far (frees are not subtracted).
  std::size_t allocations() const { return state().allocations; }
  std::size_t bytes() const { return state().bytes; }

 private:
  struct State {
    bool on = false;
    std::size_t allocations = 0;
    std::size_t bytes = 0;
  };
  static State& state() {
    static State counts;
    return counts;
  }
  static void onMalloc(const volatile void*, std::size_t size) {
    State& counts = state();
    if (!counts.on) return;
    ++counts.allocations;
    counts.bytes += size;
  }
  static void onFree(const volatile void*) {}

  bool counting_ = false;
};

}  // namespace occmap::fuzz
