#pragma once
// occmapd's side of control requests (docs/control.md): set_threshold and recapture_background
// from the network, off unless the config enables them, then authenticated (HMAC under the key
// file), within the replay window, at a bounded rate. Every message on the control channel is
// counted in exactly one of ControlCounts; only authenticated ones are answered.
//
// Threads: handle() and publishReplies() run on the LCM thread (the only one that touches LCM)
// and allocate nothing. The capture threads read each camera's CameraControl once per frame,
// without a lock. A recapture runs on a thread of its own (started only when control is enabled):
// it arms the camera's FrameRecorder, takes the median off the hot path, saves it, and offers it
// through the camera's BackgroundHandover.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <occmap/control_reply_t.hpp>

#include "base/event_fd.h"
#include "config/config.h"
#include "core/background_handover.h"
#include "core/frame_recorder.h"
#include "core/image.h"
#include "transport/control_message.h"
#include "transport/replay_window.h"
#include "transport/status_publisher.h"

namespace occmap {

class Bus;

// What a control request may change of one camera, read by its capture thread for every frame.
struct CameraControl {
  CameraControl(std::string camera_name, const Image& config_background, int config_threshold,
                double camera_fps)
      : name(std::move(camera_name)),
        fps(camera_fps),
        threshold(config_threshold),
        background(config_background),
        width(config_background.width()),
        height(config_background.height()) {}
  const std::string name;
  const double fps;
  std::atomic<int> threshold;
  BackgroundHandover background;
  FrameRecorder recorder;
  std::atomic<std::int64_t> background_utime{0};  // 0: the config's image
  // The camera's view is moved from its calibration, or it is being re-posed (set by its capture
  // thread): a background taken now would not fit its table, so recaptures are refused.
  std::atomic<bool> view_moved{false};
  const int width;
  const int height;
};

class RemoteControl {
 public:
  struct Options {
    // Where a recaptured background is saved ($STATE_DIRECTORY under systemd), or nowhere.
    std::optional<std::filesystem::path> state_directory;
    // Authenticated requests acted on at most this often; more are refused, without a reply.
    double max_requests_per_s = 10.0;
    // How many (utime, nonce) pairs the replay window remembers.
    std::size_t replay_memory = 1024;
    // Wakes the LCM thread when a recapture has a reply to send (called from the recapture thread).
    std::function<void()> wake_lcm;
  };

  // Loads the key when control is enabled (InputError if it cannot be used). `cameras` outlive it.
  RemoteControl(const Config& config, std::vector<CameraControl*> cameras, Options options);
  ~RemoteControl();
  RemoteControl(const RemoteControl&) = delete;
  RemoteControl& operator=(const RemoteControl&) = delete;

  bool enabled() const { return enabled_; }
  // The recapture thread, when enabled; stop() gives up a recapture under way and joins it.
  void start();
  void stop();

  // LCM thread: one message from the control channel; `now_us` is the daemon's clock.
  void handle(const std::uint8_t* data, std::size_t size, std::int64_t now_us, Bus& bus);
  // LCM thread, every round: sends the reply of a recapture that has ended.
  void publishReplies(Bus& bus);

  // Any thread.
  ControlCounts counts() const;

 private:
  void reply(Bus& bus, std::int64_t request_id, std::int8_t outcome, const char* format, ...)
      __attribute__((format(printf, 5, 6)));
  void recaptureLoop();
  void recapture(std::size_t camera, int frames, std::int64_t request_id);
  void finishRecapture(std::int64_t request_id, std::int8_t outcome, const char* format, ...)
      __attribute__((format(printf, 4, 5)));

  const bool enabled_;
  ControlKey key_;
  std::vector<CameraControl*> cameras_;
  Options options_;
  std::string reply_channel_;
  ReplayWindow replay_;
  // LCM thread only: the reply in the making and its bytes, both reused (no allocation).
  occmap::control_reply_t reply_{};
  std::vector<std::uint8_t> reply_bytes_;
  double tokens_;
  std::int64_t last_token_us_ = 0;

  std::atomic<std::uint64_t> disabled_{0}, malformed_{0}, bad_mac_{0}, stale_{0}, refused_{0},
      accepted_{0};

  // LCM thread -> recapture thread: one recapture at a time.
  std::atomic<bool> recapture_busy_{false};
  std::size_t job_camera_ = 0;  // written before recapture_busy_ is set, read after
  int job_frames_ = 0;
  std::int64_t job_request_id_ = 0;
  // Recapture thread -> LCM thread: the reply of a recapture that ended.
  std::atomic<bool> finished_{false};
  std::int64_t finished_request_id_ = 0;
  std::int8_t finished_outcome_ = 0;
  char finished_message_[384] = {};

  EventFd wakeup_;  // a job for the recapture thread, or stop
  std::atomic<bool> stopping_{false};
  std::thread thread_;
};

}  // namespace occmap
