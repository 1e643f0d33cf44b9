#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "base/log.h"
#include "config/rig.h"
#include "core/carve_table.h"
#include "core/fusion_kernel.h"
#include "core/map_frame.h"
#include "core/spsc_ring.h"
#include "core/triple_buffer.h"
#include "daemon/remote_control.h"

namespace occmap {

class LcmBus;

// What the daemon as a whole is doing, for status_t.state.
enum class DaemonState : std::uint8_t {
  kStarting = 0,
  kRunning = 1,
  kReloading = 2,
  kStopping = 3
};

struct PipelineOptions {
  std::chrono::steady_clock::time_point daemon_start = std::chrono::steady_clock::now();
  std::chrono::milliseconds status_period{1000};
  // A streaming camera without a frame for this long is down (its cells become unseen); with the
  // fusion thread's 100 ms wake-up that is within a second of its last frame.
  std::chrono::milliseconds camera_down_after{900};
  // A camera that has not delivered its first frame this long after start is down.
  std::chrono::milliseconds camera_start_timeout{3000};
  // With no new frame set for this long, fusion still makes a map (cameras down: all unseen), so
  // that subscribers and the watchdog see the daemon alive.
  std::chrono::milliseconds heartbeat{1000};
  // Status requests answered at most this often (a flood must not take the map's bandwidth).
  double max_status_answers_per_s = 20.0;
  // Authenticated control requests acted on at most this often (docs/control.md).
  double max_control_requests_per_s = 10.0;
  // Where a recaptured background is saved ($STATE_DIRECTORY under systemd), or nowhere.
  std::optional<std::filesystem::path> state_directory;
  // Test hooks: extra LCM subscriptions, registered in the LCM thread (their handlers run there).
  using Handler = std::function<void(const std::uint8_t* data, std::size_t size)>;
  std::vector<std::pair<std::string, Handler>> subscriptions;
  // Test hook: runs in the LCM thread at every round of its loop (ten a second at least), with the
  // daemon's own bus, to publish what another program on the network would (memq:// is private to
  // its handle); the daemon's subscriptions hear it at the next round.
  std::function<void(LcmBus& bus)> each_lcm_round;
  // Fault injection for tests of the watchdog: fusion hangs after this many maps (0 = never).
  std::uint64_t stall_fusion_after_maps = 0;
};

// Durations as a histogram: one writer thread, readers anywhere, no locks. 10 us bins up to
// 100 ms (the last holds the rest), and the exact maximum.
class TimeHistogram {
 public:
  static constexpr int kBins = 10'000;
  void record(std::int64_t ns);
  double percentileMs(double fraction) const;
  double maxMs() const {
    return static_cast<double>(max_ns_.load(std::memory_order_relaxed)) / 1e6;
  }
  std::uint64_t count() const { return count_.load(std::memory_order_relaxed); }

 private:
  std::atomic<std::uint32_t> bins_[kBins] = {};
  std::atomic<std::uint64_t> count_{0};
  std::atomic<std::int64_t> max_ns_{0};
};

// The live daemon's data path (ARCHITECTURE.md, "Threads and data flow"):
//   one capture thread per camera -> a lock-free SPSC ring per camera -> the fusion thread ->
//   a triple-buffered map -> the LCM thread (publishes maps and status, answers requests).
// Everything on that path is allocated before start(); it then takes no locks, allocates nothing
// and logs only through rate limits.
class Pipeline {
 public:
  // Takes the opened rig and one carve table per camera (same order).
  Pipeline(Rig rig, std::vector<CarveTable> tables, PipelineOptions options = {});
  ~Pipeline();
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  // Starts every thread. Throws std::runtime_error when LCM cannot be opened for the config's
  // lcm_url (then nothing runs): a daemon that can publish nothing must not say it is ready.
  void start();
  // Stops and joins every thread, in the order the data flows: the cameras first, then fusion
  // (which finishes the map it is making), then the LCM thread, which publishes what fusion made
  // last. So every map fused is published. Idempotent; returns within a frame period or so.
  void stop();

  // For the main thread (any thread may call these).
  std::uint64_t mapsFused() const { return maps_fused_.load(std::memory_order_relaxed); }
  std::uint64_t mapsPublished() const { return maps_published_.load(std::memory_order_relaxed); }
  // How long fusion takes per frame set, and how long from the arrival of a map's newest frame
  // (its capture thread's copy into the ring) to the return of its publish: what the daemon adds
  // to a frame's way to the network.
  const TimeHistogram& fusionTimes() const { return fusion_times_; }
  const TimeHistogram& publishLatency() const { return publish_latency_; }
  // Frames lost on the way, over all cameras (full rings, bad frames).
  std::uint64_t framesDropped() const;
  // Maps the publisher never took because fusion made a newer one first (it publishes the newest).
  // fused = published + skipped + publish errors.
  std::uint64_t mapsSkipped() const { return maps_skipped_.load(std::memory_order_relaxed); }
  // Rounds of the LCM thread's loop (at least ten a second while it runs): the watchdog's proof
  // that publishing is not stuck.
  std::uint64_t lcmRounds() const { return lcm_rounds_.load(std::memory_order_relaxed); }
  // Every camera has delivered a frame or been marked down: the daemon may say READY.
  bool camerasReportedIn() const;
  // One line for systemd's STATUS=: maps/s, cameras streaming, drops.
  std::string summary() const;
  void setState(DaemonState state) { state_.store(state, std::memory_order_relaxed); }
  // How control requests ended (docs/control.md), and each camera's threshold in effect.
  ControlCounts controlCounts() const { return control_->counts(); }
  int threshold(std::size_t camera) const {
    return camera_controls_[camera]->threshold.load(std::memory_order_relaxed);
  }
  const Config& config() const { return rig_.config(); }
  // After stop(): the rig (with its open cameras) and the tables, for a reload to take over.
  Rig takeRig() { return std::move(rig_); }
  std::vector<CarveTable> takeTables() { return std::move(tables_); }

 private:
  struct CapturedFrame {
    Image image;
    std::vector<std::uint8_t> changed;  // changed-pixel bits in 8 x 8 tiles (fusion_kernel.h)
    std::uint64_t sequence = 0;
    std::int64_t capture_time_us = 0;
    std::int64_t monotonic_ns = 0;
  };
  // Shared between a capture thread (writer), the fusion thread and the LCM thread (readers).
  struct alignas(64) CameraCounters {
    std::atomic<std::uint64_t> frames_in{0};
    std::atomic<std::uint64_t> frames_dropped{0};
    std::atomic<std::int64_t> last_capture_us{0};
    std::atomic<std::int64_t> last_frame_ns{0};  // monotonic; 0 before the first frame
    std::atomic<CameraState> state{CameraState::kStarting};
    std::atomic<bool> lost{false};  // the source reported the device gone; reconnecting
    RateLimit down_warnings{std::chrono::seconds(10)};  // a flapping camera logs now and then
    std::atomic<std::int32_t> reconnects{0};
    // Why the camera last failed: written on error paths only (never per frame), hence a mutex.
    void setLastError(std::string text) {
      std::lock_guard lock(error_mutex);
      last_error = std::move(text);
    }
    std::string lastError() {
      std::lock_guard lock(error_mutex);
      return last_error;
    }
    std::mutex error_mutex;
    std::string last_error;
  };

  void captureLoop(std::size_t camera);
  void fusionLoop();
  void lcmLoop(std::promise<std::string>& opened);
  void fuse(std::int64_t now_ns);
  void wake(int eventfd);

  Rig rig_;
  std::vector<CarveTable> tables_;
  PipelineOptions options_;
  FusionKernel kernel_;
  std::vector<std::unique_ptr<SpscRing<CapturedFrame>>> rings_;
  std::vector<std::unique_ptr<CameraCounters>> counters_;
  std::vector<std::unique_ptr<RateLimit>> drop_warnings_;
  // What control requests change, per camera (threshold, background), and the requests' handler;
  // declared in this order so that the handler, which points at them, goes first.
  std::vector<std::unique_ptr<CameraControl>> camera_controls_;
  std::unique_ptr<RemoteControl> control_;
  TripleBuffer<MapFrame> maps_;
  TimeHistogram fusion_times_;
  TimeHistogram publish_latency_;  // written by the LCM thread

  // Fusion thread state: the newest frame held from each ring, and whether it is new since the
  // last map.
  struct Held {
    CapturedFrame* frame = nullptr;
    bool fresh = false;
  };
  std::vector<Held> held_;
  std::vector<const std::uint8_t*> changed_;
  std::int64_t set_deadline_ns_ = 0;  // 0: no frame set open
  std::int64_t last_fused_ns_ = 0;
  std::int64_t start_ns_ = 0;

  // Stop requests, one per stage so that each drains what the one before it left.
  std::atomic<bool> stopping_{false};  // stop() was called; the capture threads end
  std::atomic<bool> stop_fusion_{false};
  std::atomic<bool> stop_lcm_{false};
  std::atomic<std::uint64_t> lcm_rounds_{0};
  std::atomic<std::uint64_t> maps_fused_{0};
  std::atomic<std::uint64_t> maps_published_{0};
  std::atomic<std::uint64_t> maps_skipped_{0};
  std::atomic<std::uint64_t> publish_errors_{0};
  std::atomic<DaemonState> state_{DaemonState::kStarting};
  int fusion_wakeup_ = -1;   // eventfd: capture threads -> fusion
  int publish_wakeup_ = -1;  // eventfd: fusion -> LCM thread
  std::vector<std::thread> threads_;
  bool started_ = false;
};

}  // namespace occmap
