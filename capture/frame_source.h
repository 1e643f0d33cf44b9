#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <string_view>

#include "core/image.h"

namespace occmap {

// One image from a camera.
struct Frame {
  ImageView image;  // valid until the source's next read()
  // The frame's number as the device counts its frames: 0 for the first frame after the source
  // opened, and one more for every frame the device made since, whether or not it reached us, so
  // that a gap is a frame lost before occmapd saw it (dropped by a driver without a free buffer,
  // lost on the network, damaged). The count goes on across reopen(): the first frame after one
  // has the number after the last frame before it (what the device made meanwhile is unknown).
  // Recorded and simulated sources number the frames they read: 0, 1, 2, ...
  std::uint64_t sequence = 0;
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

// What a source is doing: one state for every backend, as libcamera's Camera has one. Readable
// from any thread (FrameSource::state()), so that a status can show it while the capture thread
// reads.
enum class SourceState : std::uint8_t {
  kStarting,   // opened (or opened again, or rewound): no frame delivered yet
  kStreaming,  // it has delivered a frame since it was (re)opened
  kLost,       // the device is gone or failed, on its own evidence: read() says kLost until a
               // reopen() succeeds
  kEnded,      // a recorded or simulated source gave its last frame (read() said kEnd)
};

// Where a camera's frames come from. Off-line sources (files, the simulator) deliver their frames
// in order and then end; read() blocks no longer than it takes to produce the next frame.
//
// Live sources (cameras) wait for the device in read(), but never longer than about 100 ms, so that
// their thread can notice a stop. A live source does not time silence: no frame within its wait is
// kTimeout, however long the silence lasts. kLost comes only from the device's own evidence (an
// unplugged V4L2 device's ENODEV, a GigE camera's lost control channel, a camera that refuses to
// start). Whether a silent camera is down, and when to reopen it, is the caller's decision (the
// daemon's one rule for every backend: core/camera_health.h); reopen() is valid in every state,
// also while streaming, and is what brings a stalled driver back. After kLost the caller calls
// reopen() (with a growing pause between tries) until the camera is back with its settings
// applied again.
//
// The state (SourceState) changes only through the protected calls below, the same for every
// backend:
//
//   kStarting  --read() delivers a frame (delivered())---------------------> kStreaming
//   kStarting, kStreaming --the device's evidence (lost())-----------------> kLost
//   any        --reopen() succeeds, rewind() (started())-------------------> kStarting
//   any        --reopen() fails (lost())-----------------------------------> kLost
//   kStarting, kStreaming --a recording's last frame was read (ended())----> kEnded
//
// A live source that is absent when it is made starts in kLost; every other source in kStarting.
// kTimeout and kError (one bad frame) change nothing.
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
  // A live source: closes what is left of the device, opens it again and re-applies its settings;
  // in any state (a silent camera that never said kLost is reopened too). True: kStarting. False
  // while the camera is still away (kLost, lastError() says why; the caller waits and tries again).
  virtual bool reopen() { return false; }
  // A live source's transport counters, safe to call from any thread.
  virtual TransportCounters transportCounters() const { return {}; }
  // Why the last read() or reopen() failed: what and where, for a person. The reading thread's.
  const std::string& lastError() const { return error_; }
  // What the source is doing; safe to call from any thread.
  SourceState state() const { return state_.load(std::memory_order_acquire); }

 protected:
  // The transitions (see above). Each backend calls these and sets no state of its own.
  // A device opened (again) or a recording rewound: no frame yet.
  void started() { state_.store(SourceState::kStarting, std::memory_order_release); }
  // read() hands out a frame. Once per frame: a load, and a store only on the first.
  Status delivered() {
    if (state_.load(std::memory_order_relaxed) != SourceState::kStreaming) {
      state_.store(SourceState::kStreaming, std::memory_order_release);
    }
    return Status::kFrame;
  }
  // The device is gone or failed, as it says itself (never for silence alone).
  // (The reason goes into the same string each time: once it is long enough, saying why
  // allocates nothing.)
  Status lost(std::string_view message) {
    error_.assign(message);
    state_.store(SourceState::kLost, std::memory_order_release);
    return Status::kLost;
  }
  // A recording has no more frames.
  Status ended() {
    state_.store(SourceState::kEnded, std::memory_order_release);
    return Status::kEnd;
  }
  // One bad frame: no change of state.
  Status fail(std::string_view message) {
    error_.assign(message);
    return Status::kError;
  }

 private:
  std::string error_;
  std::atomic<SourceState> state_{SourceState::kStarting};
};

}  // namespace occmap
