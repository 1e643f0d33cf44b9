#pragma once
// Camera previews for a live view (issue 17, docs/daemon.md "Camera previews"): each camera's frame
// scaled down, the pixels it found changed at that size, and the map cells it decides, as a
// camera_preview_t (transport/camera_preview_message.h), made only while a client asks and at most
// twice a second per camera.
// Nothing of it is on the map's path. A capture thread looks at one atomic per frame (due()), and
// only when a preview is due shrinks its frame and changed pixels into the camera's triple buffer
// (offer(), after it has handed the frame to fusion). This thread, below the map's threads in
// priority, makes the JPEG and the message and hands the bytes to the publisher through another
// triple buffer; the publisher only sends the newest bytes of each camera. A preview that is not
// taken in time is overwritten, never queued: a slow previewer or network costs previews, not maps.
// Each camera's coverage is packed and compressed once, here, from the tables the pipeline starts
// with (a camera re-posed after a knock keeps its first coverage until the config is reloaded).
// The buffers are allocated here, before any thread starts; OpenCV's JPEG encoder allocates on
// this thread only.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <occmap/camera_preview_t.hpp>

#include "base/event_fd.h"
#include "base/rate_limit.h"
#include "base/time_histogram.h"
#include "core/carve_table.h"
#include "core/image.h"
#include "core/map_frame.h"
#include "core/triple_buffer.h"

namespace occmap {

// A frame as a capture thread hands it to the previewer: scaled down by `scale`.
struct PreviewFrame {
  std::int64_t capture_time_us = 0;
  std::uint64_t sequence = 0;
  CameraState state = CameraState::kStreaming;
  int stream_width = 0;
  int stream_height = 0;
  int scale = 1;
  int width = 0;                      // ceil(stream_width / scale)
  int height = 0;                     // ceil(stream_height / scale)
  std::vector<std::uint8_t> grey;     // width * height, row-major: each the mean of its pixels
  std::vector<std::uint8_t> changed;  // width * height: 1 when any of its stream pixels changed
};

// `image` and its changed-pixel tiles (fusion_kernel.h) scaled down by `scale` into `out`, whose
// buffers hold at least ceil(width / scale) * ceil(height / scale) bytes; `sums` is scratch of as
// many entries as the stream is wide. A preview pixel is the rounded mean of the stream pixels it
// covers and changed when any of them is.
void shrinkForPreview(ImageView image, const std::uint8_t* changed, int scale,
                      std::span<std::uint32_t> sums, PreviewFrame& out);
// `in` at twice its scale into `out` (buffers as large as `in`'s): each pixel the mean of the
// stream pixels it covers (weighted by how many each of `in`'s covers), changed when any is.
void halvePreview(const PreviewFrame& in, PreviewFrame& out);

class Previewer {
 public:
  // Each camera's name and carve table (its stream's size and coverage), in the rig's order.
  // `preview_for`: how long previews are made after the last request naming the camera (or all).
  Previewer(std::string hostname, std::span<const std::string> cameras,
            std::span<const CarveTable> tables, std::chrono::nanoseconds preview_for);
  Previewer(const Previewer&) = delete;
  Previewer& operator=(const Previewer&) = delete;

  // Publisher thread: a request for `camera`'s previews ("" for every camera) arrived at `now_ns`
  // (CLOCK_MONOTONIC). False when no camera here has that name.
  bool requested(std::string_view camera, std::int64_t now_ns);

  // Capture thread k, every frame: whether this frame is to be previewed. One atomic load while
  // no one asks; at most one frame in 0.5 s of the stream's capture time (one whose time went
  // back, a rewound recording, starts over).
  bool due(std::size_t k, std::int64_t now_ns, std::int64_t capture_time_us) {
    Camera& camera = *cameras_[k];
    if (now_ns >= camera.wanted_until_ns.load(std::memory_order_relaxed)) return false;
    if (camera.previewed && capture_time_us >= camera.previewed_us &&
        capture_time_us - camera.previewed_us < kPeriodUs) {
      return false;
    }
    camera.previewed = true;
    camera.previewed_us = capture_time_us;
    return true;
  }
  // Capture thread k, when due(): the frame (the stream's size) and its changed-pixel tiles,
  // scaled down and handed over; the previewer is woken.
  void offer(std::size_t k, ImageView image, const std::uint8_t* changed, std::uint64_t sequence,
             std::int64_t capture_time_us, CameraState state);

  // Its own thread: until stop(), each newest offer in turn; `ready` is signalled after each
  // message handed over (the publisher's wake-up).
  void run(const EventFd& ready);
  // Any thread: run() returns at its next round.
  void stop();
  // One round of the thread's: a message of each camera's newest offer; false when none was made.
  // Public for the tests, which run the previewer's work without its thread.
  bool makeNewest();

  // Publisher thread: camera k's newest message not taken yet (the encoded camera_preview_t), or
  // nullptr.
  const std::vector<std::uint8_t>* takeMessage(std::size_t k) {
    Camera& camera = *cameras_[k];
    return camera.messages.takeLatest() ? &camera.messages.readBuffer() : nullptr;
  }

  std::size_t cameraCount() const { return cameras_.size(); }
  // How long each preview took this thread (JPEG and message), previews made, previews that would
  // not fit kMaxPreviewMessageBytes even small and coarse (not sent), previews that failed.
  const TimeHistogram& times() const { return times_; }
  std::uint64_t made() const { return made_.load(std::memory_order_relaxed); }
  std::uint64_t tooLarge() const { return too_large_.load(std::memory_order_relaxed); }
  std::uint64_t failed() const { return failed_.load(std::memory_order_relaxed); }

  static constexpr std::int64_t kPeriodUs = 500'000;  // at most 2 previews a second per camera

 private:
  struct Camera {
    Camera(const std::string& hostname, const std::string& name, const CarveTable& table);
    // Until when previews are wanted (CLOCK_MONOTONIC ns; the publisher writes it), on a line of
    // its own: every frame of the camera reads it.
    alignas(64) std::atomic<std::int64_t> wanted_until_ns{INT64_MIN};
    // The capture thread's: the capture time of the last frame previewed, and its scratch (a sum
    // per stream column).
    bool previewed = false;
    std::int64_t previewed_us = 0;
    std::vector<std::uint32_t> sums;
    TripleBuffer<PreviewFrame> frames;  // capture thread -> this thread
    occmap::camera_preview_t message;   // this thread's, its fixed fields filled once
    TripleBuffer<std::vector<std::uint8_t>> messages;  // this thread -> the publisher
  };
  // Camera k's message of `frame`, handed to the publisher; false when it did not fit.
  bool make(Camera& camera, const PreviewFrame& frame);

  std::vector<std::unique_ptr<Camera>> cameras_;
  std::int64_t preview_for_ns_;
  // This thread's scratch: a preview halved (two, used in turn), the JPEG, its parameters.
  PreviewFrame halved_[2];
  std::vector<std::uint8_t> jpeg_;
  std::vector<int> jpeg_parameters_;
  RateLimit too_large_warnings_{std::chrono::seconds(60)};
  RateLimit failure_warnings_{std::chrono::seconds(60)};
  TimeHistogram times_;
  std::atomic<std::uint64_t> made_{0};
  std::atomic<std::uint64_t> too_large_{0};
  std::atomic<std::uint64_t> failed_{0};
  EventFd wakeup_;
  std::atomic<bool> stopping_{false};
};

}  // namespace occmap
