#pragma once
// Frames of one camera taken for a new background (docs/control.md, recapture_background): armed
// by one thread (the daemon's recapture thread), filled by the camera's capture thread as frames
// arrive, without a lock. Who may touch the frames is said by one atomic state: the arming thread
// while idle or filled, the capture thread while recording. A recording given up (the camera
// stopped delivering) is let go by the capture thread at its next frame, so the arming thread never
// frees or resizes memory the capture thread may be writing. No I/O, no threads of its own.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include "core/image.h"

namespace occmap {

class FrameRecorder {
 public:
  FrameRecorder() = default;
  FrameRecorder(const FrameRecorder&) = delete;
  FrameRecorder& operator=(const FrameRecorder&) = delete;

  // Arming thread: records the next `count` frames of width x height. False (nothing done) while
  // an earlier recording is under way or not yet let go. May throw std::bad_alloc.
  bool arm(int count, int width, int height) {
    if (state_.load(std::memory_order_acquire) != kIdle) return false;
    pixels_ = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    frames_.resize(pixels_ * static_cast<std::size_t>(count));
    count_ = count;
    width_ = width;
    height_ = height;
    taken_ = 0;
    state_.store(kRecording, std::memory_order_release);
    return true;
  }

  // Capture thread, once per good frame: copies it while recording. One atomic load otherwise.
  void record(ImageView frame) {
    const int state = state_.load(std::memory_order_acquire);
    if (state == kCancelled) {
      state_.store(kIdle, std::memory_order_release);  // let go: the arming thread may reuse it
      return;
    }
    if (state != kRecording || frame.width != width_ || frame.height != height_) return;
    std::uint8_t* out = frames_.data() + static_cast<std::size_t>(taken_) * pixels_;
    for (int v = 0; v < frame.height; ++v) {
      std::memcpy(out + static_cast<std::size_t>(v) * static_cast<std::size_t>(width_),
                  frame.row(v), static_cast<std::size_t>(width_));
    }
    if (++taken_ == count_) {
      int expected = kRecording;
      // Cancelled meanwhile: the arming thread has given up on these frames.
      if (!state_.compare_exchange_strong(expected, kFilled, std::memory_order_acq_rel)) {
        state_.store(kIdle, std::memory_order_release);
      }
    }
  }

  // Arming thread: every frame is in.
  bool filled() const { return state_.load(std::memory_order_acquire) == kFilled; }
  // Arming thread, once filled: the frames, one after the other.
  std::span<const std::uint8_t> frames() const { return frames_; }
  int count() const { return count_; }
  // Arming thread: done with the frames (filled) or giving up on them (recording).
  void finish() {
    int expected = kRecording;
    if (state_.compare_exchange_strong(expected, kCancelled, std::memory_order_acq_rel)) return;
    if (expected == kFilled) {
      frames_ = {};  // frees the stack (N frames)
      state_.store(kIdle, std::memory_order_release);
    }
  }

 private:
  enum : int { kIdle, kRecording, kFilled, kCancelled };
  std::atomic<int> state_{kIdle};
  std::vector<std::uint8_t> frames_;
  std::size_t pixels_ = 0;
  int count_ = 0;
  int width_ = 0;
  int height_ = 0;
  int taken_ = 0;  // capture thread only, while recording
};

}  // namespace occmap
