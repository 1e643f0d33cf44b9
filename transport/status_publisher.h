#pragma once
// The daemon's status onto the bus: status_t, and beside it control_status_t, lighting_status_t
// and view_status_t (types of their own, so that status_t keeps the fingerprint every reader built
// before them decodes; lcmtypes/control_status_t.lcm, lighting_status_t.lcm, view_status_t.lcm).
// The pipeline fills a DaemonReport of plain counters; this turns it into the messages, with rates
// measured over the last few periodic statuses, and sends them. The messages are filled in place:
// once their strings and vectors have their size (the first time), publishing allocates nothing.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <occmap/control_status_t.hpp>
#include <occmap/lighting_status_t.hpp>
#include <occmap/status_t.hpp>
#include <occmap/view_status_t.hpp>

#include "core/map_frame.h"
#include "transport/bus.h"
#include "transport/rate_window.h"

namespace occmap {

// What the daemon as a whole is doing, for status_t.state.
enum class DaemonState : std::uint8_t {
  kStarting = 0,
  kRunning = 1,
  kReloading = 2,
  kStopping = 3
};

// How many messages on the control channel ended each way (control_status_t).
struct ControlCounts {
  std::uint64_t disabled = 0;
  std::uint64_t malformed = 0;
  std::uint64_t bad_mac = 0;
  std::uint64_t stale = 0;
  std::uint64_t refused = 0;
  std::uint64_t accepted = 0;
};

// The longest error text a status carries (longer ones are cut): every string that holds one is
// reserved to it once, so that a camera's new, longer error allocates nothing.
inline constexpr std::size_t kMaxErrorText = 256;

// One camera, as the status tells it (camera_status_t).
struct CameraReport {
  std::string name;    // set once
  std::string source;  // set once
  CameraState state = CameraState::kStarting;
  std::uint64_t frames_in = 0;
  std::uint64_t frames_dropped = 0;
  std::int64_t last_capture_utime = 0;
  std::int64_t frames_incomplete = 0;
  std::int64_t missing_packets = 0;
  std::int64_t resent_packets = 0;
  std::int64_t underruns = 0;
  std::int32_t reconnects = 0;
  std::string last_error;  // its capacity reserved once, so that filling it allocates nothing
  int threshold = 0;
  std::int64_t background_utime = 0;  // 0: the config's image
  // The light's model (lighting_status_t).
  bool lighting_adapt = false;
  double lighting_gain = 1.0;
  double lighting_agreement = 1.0;
  bool lighting_explained = true;
  std::uint64_t unexplained_frames = 0;
  // Whether it looks where its calibration says (view_status_t; its VIEW constants).
  std::int8_t view = 0;
  double view_shift_x_px = 0;
  double view_shift_y_px = 0;
  double view_turn_deg = 0;
  double view_residual_px = 0;
  std::int64_t view_checked_utime = 0;
  std::int32_t reposes = 0;
  double reposed_turn_deg = 0;
  std::int64_t reposed_utime = 0;
};

struct DaemonReport {
  std::string hostname;     // set once
  std::string config_file;  // set once
  DaemonState state = DaemonState::kStarting;
  double uptime_s = 0;
  std::uint64_t maps_published = 0;
  std::uint64_t publish_errors = 0;
  double fusion_p50_ms = 0;
  double fusion_p99_ms = 0;
  bool control_enabled = false;
  ControlCounts control;
  std::vector<CameraReport> cameras;
};

class StatusPublisher {
 public:
  // `now_ns` (CLOCK_MONOTONIC) starts the rate window.
  StatusPublisher(std::string status_channel, std::size_t cameras, std::int64_t now_ns);

  // Sends the status and control status of `report` at `now_ns`, answering `request_id` (-1: the
  // periodic status, which also moves the rate window on). Publish failures are counted in
  // errors(), and the report's publish_errors is the caller's to add them to.
  void publish(Bus& bus, const DaemonReport& report, std::int64_t request_id, std::int64_t now_ns);
  std::uint64_t errors() const { return errors_; }

 private:
  std::string status_channel_;
  std::string control_status_channel_;
  std::string lighting_status_channel_;
  std::string view_status_channel_;
  RateWindow rates_;
  occmap::status_t status_{};
  occmap::control_status_t control_status_{};
  occmap::lighting_status_t lighting_status_{};
  occmap::view_status_t view_status_{};
  std::vector<std::uint8_t> buffer_;
  std::uint64_t errors_ = 0;
};

}  // namespace occmap
