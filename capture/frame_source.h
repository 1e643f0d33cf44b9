#pragma once

#include <cstdint>
#include <string>

#include "core/image.h"

namespace occmap {

// One image from a camera.
struct Frame {
  ImageView image;                   // valid until the source's next read()
  std::uint64_t sequence = 0;        // 0, 1, 2, ... in the order the source delivered them
  std::int64_t capture_time_us = 0;  // host time of capture, microseconds since the Unix epoch
};

// Where a camera's frames come from. Off-line sources (files, the simulator) deliver their frames
// in order and then end; read() blocks no longer than it takes to produce the next frame.
class FrameSource {
 public:
  enum class Status { kFrame, kEnd, kError };

  FrameSource() = default;
  virtual ~FrameSource() = default;
  FrameSource(const FrameSource&) = delete;
  FrameSource& operator=(const FrameSource&) = delete;

  // Stream size: every frame has it (a frame of another size is an error).
  virtual int width() const = 0;
  virtual int height() const = 0;
  // Frames this source will deliver in all, if it knows (0 = unknown or endless).
  virtual std::uint64_t frameCount() const { return 0; }
  virtual Status read(Frame& frame) = 0;
  // A recorded or simulated source starts over from its first frame (the daemon loops them);
  // false for a source that cannot (a live camera).
  virtual bool rewind() { return false; }
  // Whether read() waits for a device (a camera) rather than producing frames as fast as asked:
  // the daemon paces the others at their configured rate.
  virtual bool isLive() const { return false; }
  // Why the last read() failed: what and where, for a person.
  const std::string& lastError() const { return error_; }

 protected:
  Status fail(std::string message) {
    error_ = std::move(message);
    return Status::kError;
  }

 private:
  std::string error_;
};

// The host's wall clock in microseconds since the Unix epoch, as LCM's utime has it.
std::int64_t hostTimeMicroseconds();

}  // namespace occmap
