#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "core/image.h"

namespace occmap {

// One image from a camera.
struct Frame {
  ImageView image;                   // valid until the source's next read()
  std::uint64_t sequence = 0;        // 0, 1, 2, ... in the order the source delivered them
  std::int64_t capture_time_us = 0;  // host time of capture, microseconds since the Unix epoch
  // What a camera says of the frame itself (0 where a source has none): its own clock, and its
  // frame (block) id, which cameras number in their own way and may wrap (GigE Vision 1.x: 16 bit).
  std::uint64_t device_time_ns = 0;
  std::uint64_t device_frame_id = 0;
};

// What a camera's transport counts (GigE Vision / USB3 Vision streams, V4L2). Sources keep these
// in atomics: the daemon's LCM thread reads them while the capture thread runs.
struct TransportCounters {
  std::int64_t frames_incomplete =
      0;  // arrived damaged (packets missing, V4L2_BUF_FLAG_ERROR), dropped
  std::int64_t missing_packets = 0;
  std::int64_t resent_packets = 0;
  std::int64_t underruns = 0;  // frames lost because the source had no free buffer
};

// Where a camera's frames come from. Off-line sources (files, the simulator) deliver their frames
// in order and then end; read() blocks no longer than it takes to produce the next frame.
//
// Live sources (cameras) wait for the device in read(), but never longer than about 100 ms, so that
// their thread can notice a stop; a camera that is unplugged, powered off or stops answering makes
// read() return kLost, and the caller then calls reopen() (with a growing pause between tries)
// until the camera is back with its settings applied again.
class FrameSource {
 public:
  enum class Status {
    kFrame,    // `frame` holds the next frame
    kEnd,      // a recorded source has no more frames (see rewind())
    kError,    // this frame is bad (corrupt, wrong size, a device error): skip it, go on
    kTimeout,  // a live source had no frame within its wait: call read() again
    kLost,     // the device is gone or failed: call reopen() until it returns true
  };

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
  // A live source: closes what is left of the device, opens it again and re-applies its settings.
  // False while the camera is still away (the caller waits and tries again).
  virtual bool reopen() { return false; }
  // A live source's transport counters, safe to call from any thread.
  virtual TransportCounters transportCounters() const { return {}; }
  // Why the last read() failed: what and where, for a person.
  const std::string& lastError() const { return error_; }

 protected:
  // Into the same string each time: once it is long enough, saying why allocates nothing.
  Status fail(std::string_view message) {
    error_.assign(message);
    return Status::kError;
  }
  Status lost(std::string_view message) {
    error_.assign(message);
    return Status::kLost;
  }

 private:
  std::string error_;
};

}  // namespace occmap
