#pragma once
// Whether a camera is alive: the one rule for every backend (Aravis, V4L2, files, the simulator).
// A camera is STARTING until its first frame, STREAMING while its frames keep coming, DOWN when it
// has been silent too long or its source said the device is gone; a DOWN camera's cells turn
// unseen. The same silence makes the capture thread reopen a live camera (a stalled driver comes
// back that way), so "down" has one meaning and one timer.
//
// Time is always an argument (CLOCK_MONOTONIC ns): the rule is plain code that tests drive by hand.
// Threads: the camera's capture thread calls the mutators; any thread may call state() and
// stalled(). Nothing here allocates, locks or reads a clock.

#include <algorithm>
#include <atomic>
#include <cstdint>

#include "core/map_frame.h"

namespace occmap {

struct CameraHealthPolicy {
  // Silence after a frame that makes a camera down, at least (a slow camera gets three of its
  // frame periods): with the fusion thread's 100 ms wake-up, down within a second of its last
  // frame.
  std::int64_t down_after_ns = 900'000'000;
  // How long a camera may take to deliver its first frame after it was opened (or reopened).
  std::int64_t first_frame_timeout_ns = 3'000'000'000;

  // The silence that makes a camera of this frame rate down: down_after_ns, or three frame
  // periods when that is longer (fps 0: unknown, down_after_ns).
  std::int64_t downAfterNs(double fps) const {
    if (fps <= 0) return down_after_ns;
    return std::max(down_after_ns, static_cast<std::int64_t>(3e9 / fps));
  }
};

class CameraHealth {
 public:
  CameraHealth(CameraHealthPolicy policy, double fps)
      : down_after_ns_(policy.downAfterNs(fps)),
        first_frame_timeout_ns_(policy.first_frame_timeout_ns) {}
  CameraHealth(const CameraHealth&) = delete;
  CameraHealth& operator=(const CameraHealth&) = delete;

  // Capture thread: the source was opened (or reopened) at `now`: its first frame is awaited.
  void opened(std::int64_t now) {
    opened_ns_.store(now, std::memory_order_relaxed);
    lost_.store(false, std::memory_order_relaxed);
  }
  // Capture thread: a frame arrived at `now`.
  void frameArrived(std::int64_t now) { last_frame_ns_.store(now, std::memory_order_relaxed); }
  // Capture thread: the source said the device is gone (or the silence made the thread give up on
  // it): down until it is reopened and delivers again.
  void lost() { lost_.store(true, std::memory_order_relaxed); }

  // Any thread: the camera's state at `now`. After a reopen a camera stays DOWN until its first
  // new frame (its old frames are too old to vouch for anything).
  CameraState state(std::int64_t now) const {
    if (lost_.load(std::memory_order_relaxed)) return CameraState::kDown;
    const std::int64_t last = last_frame_ns_.load(std::memory_order_relaxed);
    if (last == 0) {
      return now - opened_ns_.load(std::memory_order_relaxed) > first_frame_timeout_ns_
                 ? CameraState::kDown
                 : CameraState::kStarting;
    }
    if (opened_ns_.load(std::memory_order_relaxed) > last) return CameraState::kDown;  // reopened
    return now - last > down_after_ns_ ? CameraState::kDown : CameraState::kStreaming;
  }
  // Any thread: whether the camera has been silent past its limit since its last frame or its
  // (re)opening, whichever came later: the capture thread then gives the device up and reopens.
  bool stalled(std::int64_t now) const {
    const std::int64_t last = last_frame_ns_.load(std::memory_order_relaxed);
    const std::int64_t opened = opened_ns_.load(std::memory_order_relaxed);
    if (last > opened) return now - last > down_after_ns_;
    return now - opened > first_frame_timeout_ns_;
  }
  // How long the camera has been silent at `now` (since its last frame, or its opening).
  std::int64_t silenceNs(std::int64_t now) const {
    return now - std::max(last_frame_ns_.load(std::memory_order_relaxed),
                          opened_ns_.load(std::memory_order_relaxed));
  }
  bool isLost() const { return lost_.load(std::memory_order_relaxed); }
  std::int64_t downAfterNs() const { return down_after_ns_; }

 private:
  const std::int64_t down_after_ns_;
  const std::int64_t first_frame_timeout_ns_;
  std::atomic<std::int64_t> opened_ns_{0};
  std::atomic<std::int64_t> last_frame_ns_{0};
  std::atomic<bool> lost_{false};
};

}  // namespace occmap
