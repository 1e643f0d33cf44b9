#pragma once
// Two small time rules of the capture threads, with time passed in (CLOCK_MONOTONIC ns) so that
// tests drive them by hand. Nothing here reads a clock or sleeps.

#include <algorithm>
#include <cstdint>

namespace occmap {

// Recorded and simulated cameras run at their configured rate, as a camera would: the frame
// times are start + n * period; a thread that fell far behind (a slow machine, a stop in a
// debugger) starts again from now instead of bursting to catch up.
class FramePacer {
 public:
  FramePacer(double fps, std::int64_t now)
      : period_ns_(static_cast<std::int64_t>(1e9 / fps)), next_ns_(now) {}
  // When to read the next frame, given that it is `now`.
  std::int64_t next(std::int64_t now) {
    if (next_ns_ < now - period_ns_) next_ns_ = now;
    const std::int64_t due = next_ns_;
    next_ns_ += period_ns_;
    return due;
  }

 private:
  std::int64_t period_ns_;
  std::int64_t next_ns_;
};

// How long to wait between tries to reopen a lost camera: 0.1 s, doubling after each failure up
// to 1 s (a try that finds nothing already takes about a second of Aravis's discovery), back to
// 0.1 s once it is back.
class ReconnectBackoff {
 public:
  static constexpr std::int64_t kFirstNs = 100'000'000;
  static constexpr std::int64_t kLongestNs = 1'000'000'000;

  // The camera was lost at `now`: the first try is due after the shortest wait.
  void lost(std::int64_t now) {
    wait_ns_ = kFirstNs;
    next_try_ns_ = now + wait_ns_;
  }
  bool due(std::int64_t now) const { return now >= next_try_ns_; }
  std::int64_t nextTryNs() const { return next_try_ns_; }
  // A try failed at `now`: the next waits twice as long, at most kLongestNs.
  void failed(std::int64_t now) {
    wait_ns_ = std::min(wait_ns_ * 2, kLongestNs);
    next_try_ns_ = now + wait_ns_;
  }

 private:
  std::int64_t wait_ns_ = kFirstNs;
  std::int64_t next_try_ns_ = 0;
};

}  // namespace occmap
