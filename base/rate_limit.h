#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>

namespace occmap {

// Lets a repeated warning through at most once per interval and counts what it held back, so a
// camera dropping frames at 60 Hz writes one line every ten seconds, not sixty a second.
// Lock-free: safe to share between threads, cheap enough for the hot path.
class RateLimit {
 public:
  explicit RateLimit(std::chrono::nanoseconds interval) : interval_ns_(interval.count()) {}
  // True when a line may be written at `now_ns` (CLOCK_MONOTONIC); `suppressed` then holds how
  // many were held back since.
  bool allow(std::int64_t now_ns, std::uint64_t& suppressed);
  // The same, now.
  bool allow(std::uint64_t& suppressed);

 private:
  std::int64_t interval_ns_;
  std::atomic<std::int64_t> next_ns_{INT64_MIN};
  std::atomic<std::uint64_t> held_{0};
};

}  // namespace occmap
