#pragma once

#include <atomic>
#include <cstdint>

namespace occmap {

// Durations as a histogram: one writer thread, readers anywhere, no locks. 10 us bins up to
// 100 ms (the last holds the rest), and the exact maximum.
class TimeHistogram {
 public:
  static constexpr int kBins = 10'000;
  void record(std::int64_t ns);
  double percentileMs(double fraction) const;
  double maxMs() const {
    return static_cast<double>(max_ns_.load(std::memory_order_relaxed)) / 1e6;
  }
  std::uint64_t count() const { return count_.load(std::memory_order_relaxed); }

 private:
  std::atomic<std::uint32_t> bins_[kBins] = {};
  std::atomic<std::uint64_t> count_{0};
  std::atomic<std::int64_t> max_ns_{0};
};

}  // namespace occmap
