#pragma once
// The live daemon's data path (ARCHITECTURE.md, "Threads and data flow"):
//   one capture thread per camera -> the camera's newest frame (a triple buffer of changed-pixel
//   masks) -> the fusion thread -> a triple-buffered map -> the publisher thread (maps, status,
//   requests on the bus).
// This is the wiring: the threads and what they hand each other. The rules they follow are plain
// code elsewhere, with time passed in: camera health (core/camera_health.h), frame sets
// (core/frame_set.h), pacing and reconnection (core/pacing.h), the fusion (core/fusion_kernel.h),
// publishing (transport/map_publisher.h, status_publisher.h, status_requests.h). Camera previews
// for a live view are made beside this path, only while a client asks (daemon/previewer.h).
// Everything on the data path is allocated before start(); it then takes no locks, allocates
// nothing and logs only through rate limits. No exception leaves a thread: a camera whose thread
// fails goes down with the reason in its status; a fusion or publisher thread that fails ends the
// maps, failed() says so, and occmapd exits for systemd to restart it.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "base/event_fd.h"
#include "base/rate_limit.h"
#include "base/shared_text.h"
#include "base/time_histogram.h"
#include "config/prepared_rig.h"
#include "core/camera_health.h"
#include "core/changed_pixels.h"
#include "core/frame_set.h"
#include "core/fusion_kernel.h"
#include "core/map_frame.h"
#include "core/triple_buffer.h"
#include "core/zones.h"
#include "daemon/footprints_stage.h"
#include "daemon/pose_handover.h"
#include "daemon/previewer.h"
#include "daemon/remote_control.h"
#include "daemon/reposer.h"
#include "transport/bus.h"
#include "transport/footprints_publisher.h"
#include "transport/map_publisher.h"
#include "transport/status_publisher.h"

namespace occmap {

struct PipelineOptions {
  std::chrono::steady_clock::time_point daemon_start = std::chrono::steady_clock::now();
  std::chrono::milliseconds status_period{1000};
  // When a camera is down (silence after its frames, or no first frame): core/camera_health.h.
  CameraHealthPolicy camera_health;
  // With no new frame set for this long, fusion still makes a map (cameras down: all unseen), so
  // that subscribers and the watchdog see the daemon alive.
  std::chrono::milliseconds heartbeat{1000};
  // Status requests answered at most this often (a flood must not take the map's bandwidth).
  double max_status_answers_per_s = 20.0;
  // Authenticated control requests acted on at most this often (docs/control.md).
  double max_control_requests_per_s = 10.0;
  // Where a recaptured background is saved ($STATE_DIRECTORY under systemd), or nowhere.
  std::optional<std::filesystem::path> state_directory;
  // How long a camera's previews (camera_preview_t) are made after the last request naming it (or
  // all): clients ask again every few seconds while they show them. Tests shorten it.
  std::chrono::milliseconds preview_for{10'000};
};

class Pipeline {
 public:
  // Takes the prepared rig (one carve table per camera) and the bus to publish on, which only
  // the publisher thread uses from start() on.
  Pipeline(PreparedRig prepared, std::unique_ptr<Bus> bus, PipelineOptions options = {});
  ~Pipeline();
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  // Starts every thread: the publisher first, so that it listens before the first map exists.
  void start();
  // Stops and joins every thread, in the order the data flows: the cameras first, then fusion
  // (which finishes the map it is making), then the publisher, which sends what fusion made last.
  // So every map fused is published. Idempotent; returns within a frame period or so.
  void stop();

  // For the main thread (any thread may call these).
  std::uint64_t mapsFused() const { return maps_fused_.load(std::memory_order_relaxed); }
  std::uint64_t mapsPublished() const { return map_publisher_.published(); }
  // How long fusion takes per frame set, and how long from the arrival of a map's newest frame
  // (its capture thread's hand-off) to the return of its publish: what the daemon adds to a
  // frame's way to the network.
  const TimeHistogram& fusionTimes() const { return fusion_times_; }
  const TimeHistogram& publishLatency() const { return map_publisher_.latency(); }
  // Frames lost on the way, over all cameras (bad frames, wrong sizes).
  std::uint64_t framesDropped() const;
  // Frames fusion never took because a newer one of the same camera came first (fusion fuses the
  // newest): not lost, overtaken.
  std::uint64_t framesOvertaken() const;
  // Maps the publisher never took because fusion made a newer one first (it publishes the newest).
  // fused = published + skipped + publish errors.
  std::uint64_t mapsSkipped() const { return maps_skipped_.load(std::memory_order_relaxed); }
  // Rounds of the publisher thread's loop (at least ten a second while it runs): the watchdog's
  // proof that publishing is not stuck.
  std::uint64_t publisherRounds() const {
    return publisher_rounds_.load(std::memory_order_relaxed);
  }
  // Every camera has delivered a frame or been marked down: the daemon may say READY.
  bool camerasReportedIn() const;
  // The fusion or the publisher thread ended on an error (logged): no more maps will come.
  bool failed() const { return failed_.load(std::memory_order_relaxed); }
  // One line for systemd's STATUS=: maps/s, cameras streaming, drops.
  std::string summary() const;
  void setState(DaemonState state) { state_.store(state, std::memory_order_relaxed); }
  // How control requests ended (docs/control.md), and each camera's threshold in effect.
  ControlCounts controlCounts() const { return control_->counts(); }
  int threshold(std::size_t camera) const {
    return cameras_[camera]->control.threshold.load(std::memory_order_relaxed);
  }
  const Config& config() const { return prepared_.rig.config(); }
  // Camera previews (daemon/previewer.h): how long each took the previewer's thread, how many were
  // made and sent, and how many would not fit a datagram (not sent).
  const TimeHistogram& previewTimes() const { return previewer_->times(); }
  std::uint64_t previewsMade() const { return previewer_->made(); }
  std::uint64_t previewsPublished() const {
    return previews_published_.load(std::memory_order_relaxed);
  }
  std::uint64_t previewsTooLarge() const { return previewer_->tooLarge(); }
  // After stop(): the rig (with its open cameras) and the tables, for a reload to take over.
  PreparedRig takePrepared() { return std::move(prepared_); }

 private:
  // What a capture thread hands fusion: the changed-pixel mask of a frame, not the frame.
  struct CapturedFrame {
    std::vector<std::uint8_t> changed;  // changed-pixel bits in 8 x 8 tiles (fusion_kernel.h)
    // False when the light's model did not explain the frame (core/lighting_model.h): fusion
    // leaves the camera out, so that what only it sees is unseen rather than occupied.
    bool explained = true;
    std::uint32_t generation = 0;  // of the kernel's table it was marked with (a re-pose)
    std::uint64_t sequence = 0;
    std::int64_t capture_time_us = 0;
    std::int64_t arrival_ns = 0;  // CLOCK_MONOTONIC, when the capture thread had it
  };
  // One camera's stage: its capture thread writes, fusion and the publisher read.
  struct Camera {
    Camera(const RigCamera& camera, double fps, const CameraHealthPolicy& policy, int width,
           int height);
    CameraHealth health;
    CameraControl control;         // threshold and background as control requests change them
    ChangedPixels changed_pixels;  // capture thread only: difference and the light's model
    // The last frame's light was not explained (written by the capture thread), and the model's
    // figures, for the status (lighting_status_t).
    std::atomic<bool> unexplained{false};
    std::atomic<double> lighting_gain{1.0};
    std::atomic<double> lighting_agreement{1.0};
    std::atomic<std::uint64_t> unexplained_frames{0};
    // Whether it looks where its calibration says, and how it moved (view_status_t): written by
    // the capture thread after each check of its view (ChangedPixels), read by the publisher. The
    // figures of one check may reach a status with those of the next: a second apart, either tells.
    std::atomic<std::int8_t> view{0};
    std::atomic<double> view_shift_x_px{0};
    std::atomic<double> view_shift_y_px{0};
    std::atomic<double> view_turn_deg{0};
    std::atomic<double> view_residual_px{0};
    std::atomic<std::int64_t> view_checked_us{0};
    // Re-posing after a knock (core/repose.h, daemon/reposer.h): the capture thread starts the job
    // and installs its result; what it then differences against and votes with is the re-posed
    // camera's (until a recapture offers another background). The re-posed backgrounds are all
    // kept: the light's model knows its background by its address.
    Reposer reposer;
    const Image* offered = nullptr;             // the control's background last seen
    const Image* reposed_background = nullptr;  // in use while not nullptr
    const Image* floor_mask = nullptr;          // the mask the table in use was built with
    std::vector<std::unique_ptr<Image>> reposed_images;
    std::atomic<std::int32_t> reposes{0};
    std::atomic<double> reposed_turn_deg{0};
    std::atomic<std::int64_t> reposed_utime{0};
    // The newest frame: when fusion is behind, the oldest gives way (fusion only takes the newest).
    TripleBuffer<CapturedFrame> frames;
    alignas(64) std::atomic<std::uint64_t> frames_in{0};
    std::atomic<std::uint64_t> frames_dropped{0};
    std::atomic<std::uint64_t> frames_overtaken{0};
    std::atomic<std::int64_t> last_capture_us{0};
    std::atomic<std::int32_t> reconnects{0};
    // Why it last failed or went down, in fixed room: the status allocates nothing to carry it.
    SharedText<kMaxErrorText> last_error;
    RateLimit error_warnings{std::chrono::seconds(10)};  // bad frames
    RateLimit down_warnings{std::chrono::seconds(10)};   // a flapping camera logs now and then
    RateLimit lighting_notes{std::chrono::seconds(10)};  // explained by the light, or not
  };

  void captureLoop(std::size_t camera);
  void loseCamera(std::size_t camera, const char* why);
  void noteLighting(std::size_t camera, bool explained);
  void noteView(std::size_t camera);
  void repose(std::size_t camera, const Image& background);
  std::string saveReposedCalibration(const std::string& name, const occmap::Camera& camera) const;
  void fusionLoop();
  void noteState(std::size_t camera, CameraState state, std::int64_t now);
  void fuse(std::int64_t now);
  void publisherLoop();
  // The publisher's part of the footprints: the zones of the map just sent, and the tracks found
  // since, under the seq their map was sent with.
  void publishZones(Bus& bus, const MapFrame& map);
  void publishTracks(Bus& bus);
  void fillReport(std::int64_t now);
  // Runs a thread's body; what it throws is logged (and, for fusion and the publisher, failed()).
  static constexpr std::size_t kNoCamera = SIZE_MAX;
  template <typename Body>
  void guarded(const char* thread, std::size_t camera, Body&& body);
  void threadFailed(const char* thread, std::size_t camera, const char* what);

  PreparedRig prepared_;
  std::unique_ptr<Bus> bus_;
  PipelineOptions options_;
  FusionKernel kernel_;
  std::vector<std::unique_ptr<Camera>> cameras_;
  std::unique_ptr<RemoteControl> control_;  // points at the cameras' controls: declared after them

  // Fusion thread state.
  FrameSetAssembler frame_set_;
  std::vector<CameraState> states_;         // each camera's state at the last round
  std::vector<CameraState> logged_states_;  // what the log last said of it
  std::vector<const std::uint8_t*> changed_;
  std::vector<const std::uint8_t*> footprint_masks_;  // what the detector is offered
  std::vector<std::uint32_t> generations_;
  TripleBuffer<MapFrame> maps_;
  TimeHistogram fusion_times_;
  std::optional<Zones> zones_;
  // A camera re-posed after a knock, for the zones' hidden floor (Zones::tellsHiddenFloor): its
  // pose and its zone cells' columns in the new image, made on its capture thread (repose()) and
  // taken by the fusion thread with the camera's first frame of that pose.
  struct ZonePose {
    occmap::Camera camera;
    std::vector<HiddenFloor::Rectangle> sights;
  };
  PoseHandover<ZonePose> zone_poses_;

  // The people on the maps: their own thread (footprints_stage.h), nullptr when off.
  std::unique_ptr<FootprintsStage> footprints_;
  std::thread footprints_thread_;

  // Camera previews for a live view: their own thread, fed by the capture threads only while a
  // client asks (previewer.h); the publisher sends what it makes.
  std::unique_ptr<Previewer> previewer_;
  std::thread previewer_thread_;
  std::atomic<std::uint64_t> previews_published_{0};
  std::uint64_t preview_requests_ignored_ = 0;  // publisher thread: malformed requests

  // Publisher thread state.
  MapPublisher map_publisher_;
  FootprintsPublisher footprints_publisher_;
  // The seq each of the last maps was sent with, by the fusion's number (for the tracks found on
  // them later): a detector more than this many maps behind names no map (seq -1).
  struct SentMap {
    std::uint64_t fused = UINT64_MAX;
    std::int64_t seq = -1;
  };
  static constexpr std::size_t kSentMaps = 64;
  SentMap sent_maps_[kSentMaps];
  DaemonReport report_;

  // Stop requests, one per stage so that each drains what the one before it left.
  std::atomic<bool> stopping_{false};  // stop() was called; the capture threads end
  std::atomic<bool> stop_fusion_{false};
  std::atomic<bool> stop_publisher_{false};
  std::atomic<bool> failed_{false};
  std::atomic<std::uint64_t> publisher_rounds_{0};
  std::atomic<std::uint64_t> maps_fused_{0};
  std::atomic<std::uint64_t> maps_skipped_{0};
  std::atomic<DaemonState> state_{DaemonState::kStarting};
  EventFd fusion_wakeup_;   // capture threads -> fusion
  EventFd publish_wakeup_;  // fusion -> publisher
  std::vector<std::thread> threads_;
  bool started_ = false;
};

}  // namespace occmap
