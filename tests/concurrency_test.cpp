// The lock-free part of the pipeline, the triple buffer (each camera's newest frame, the map for
// the publisher), with two threads. Run under ThreadSanitizer too (scripts/test), which checks the
// memory ordering.
#include <atomic>
#include <cstdint>
#include <numeric>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "core/triple_buffer.h"

namespace occmap {
namespace {

// Each camera's newest frame and the map handed to the publisher: when the reader is behind, the
// oldest buffer gives way, and the writer is told so (counted as overtaken, or skipped).
TEST(TripleBuffer, WhenTheReaderIsBehindTheOldestGivesWayAndTheWriterIsTold) {
  TripleBuffer<int> buffers(0, 0, 0);
  EXPECT_FALSE(buffers.takeLatest()) << "nothing published yet";
  buffers.writeBuffer() = 1;
  EXPECT_FALSE(buffers.publish()) << "nothing was overwritten";
  buffers.writeBuffer() = 2;
  EXPECT_TRUE(buffers.publish()) << "1 was never taken: it gave way to 2";
  buffers.writeBuffer() = 3;
  EXPECT_TRUE(buffers.publish());
  ASSERT_TRUE(buffers.takeLatest());
  EXPECT_EQ(buffers.readBuffer(), 3) << "the reader gets the newest, never an older one";
  EXPECT_FALSE(buffers.takeLatest()) << "nothing newer since";
  EXPECT_EQ(buffers.readBuffer(), 3) << "the buffer taken stays the reader's";
  buffers.writeBuffer() = 4;
  EXPECT_FALSE(buffers.publish()) << "3 was taken: nothing given way";
  ASSERT_TRUE(buffers.takeLatest());
  EXPECT_EQ(buffers.readBuffer(), 4);
}

TEST(TripleBuffer, ReaderAlwaysGetsAWholeBufferAndNeverGoesBack) {
  struct Buffer {
    std::uint64_t sequence = 0;
    std::vector<std::uint64_t> cells = std::vector<std::uint64_t>(256, 0);
  };
  TripleBuffer<Buffer> buffers(Buffer{}, Buffer{}, Buffer{});
  constexpr std::uint64_t kWrites = 100000;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (std::uint64_t i = 1; i <= kWrites; ++i) {
      Buffer& b = buffers.writeBuffer();
      b.sequence = i;
      std::fill(b.cells.begin(), b.cells.end(), i);
      buffers.publish();
    }
    done.store(true, std::memory_order_release);
  });
  std::uint64_t last = 0;
  std::uint64_t taken = 0;
  bool whole = true, forward = true;
  for (;;) {
    const bool finished = done.load(std::memory_order_acquire);
    if (buffers.takeLatest()) {
      const Buffer& b = buffers.readBuffer();
      for (const std::uint64_t cell : b.cells) whole = whole && cell == b.sequence;
      forward = forward && b.sequence > last;
      last = b.sequence;
      ++taken;
    } else if (finished) {
      break;
    }
  }
  writer.join();
  EXPECT_TRUE(whole) << "the reader saw a buffer the writer was still filling";
  EXPECT_TRUE(forward) << "the reader went back to an older buffer";
  EXPECT_EQ(last, kWrites) << "the newest buffer must reach the reader";
  EXPECT_GT(taken, 0u);
}

}  // namespace
}  // namespace occmap
