#pragma once

#include <atomic>
#include <cstdint>
#include <utility>

namespace occmap {

// Three pre-built buffers between one writer and one reader (the fusion thread and the publisher):
// the writer always has a buffer to fill, the reader always gets the newest complete one, neither
// ever waits or locks. A buffer the reader did not take in time is overwritten: the reader skips to
// the newest, which is what a live map wants.
template <typename T>
class TripleBuffer {
 public:
  TripleBuffer(T a, T b, T c) : buffers_{std::move(a), std::move(b), std::move(c)} {}
  TripleBuffer(const TripleBuffer&) = delete;
  TripleBuffer& operator=(const TripleBuffer&) = delete;

  // Writer: the buffer to fill.
  T& writeBuffer() noexcept { return buffers_[write_]; }
  // Writer: makes the filled buffer the newest and takes another to fill. True when that
  // overwrote a buffer the reader never took (the reader was too slow for it: it is skipped).
  bool publish() noexcept {
    const std::uint8_t previous =
        middle_.exchange(static_cast<std::uint8_t>(write_ | kFresh), std::memory_order_acq_rel);
    write_ = previous & kIndex;
    return (previous & kFresh) != 0;
  }

  // Reader: moves to the newest published buffer; false when nothing new was published.
  bool takeLatest() noexcept {
    if ((middle_.load(std::memory_order_relaxed) & kFresh) == 0) return false;
    read_ = middle_.exchange(read_, std::memory_order_acq_rel) & kIndex;
    return true;
  }
  // Reader: the buffer taken last (the reader may change it: it is the reader's until the next
  // take).
  T& readBuffer() noexcept { return buffers_[read_]; }
  const T& readBuffer() const noexcept { return buffers_[read_]; }

 private:
  static constexpr std::uint8_t kIndex = 0x3;
  static constexpr std::uint8_t kFresh = 0x4;
  T buffers_[3];
  std::uint8_t write_ = 0;
  std::uint8_t read_ = 1;
  alignas(64) std::atomic<std::uint8_t> middle_{2};
};

}  // namespace occmap
