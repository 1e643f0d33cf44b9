#pragma once
// A merge node's status onto the bus (merge_status_t on the status channel's name + "_MERGE",
// transport/merge_status_message.h). The merge daemon fills a MergeReport of plain counters; this
// turns it into the message, with the maps per second of the node and of each input measured over
// the last few periodic statuses, and sends it. The message is filled in place.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <occmap/merge_status_t.hpp>

#include "transport/bus.h"
#include "transport/rate_window.h"
#include "transport/status_publisher.h"

namespace occmap {

// merge_input_status_t.STATE_*.
enum class MergeInputState : std::int8_t { kNeverHeard = 0, kFresh = 1, kDown = 2 };

// One input, as the status tells it (merge_input_status_t).
struct MergeInputReport {
  std::string name;     // set once
  std::string channel;  // set once
  MergeInputState state = MergeInputState::kNeverHeard;
  std::uint64_t maps = 0;
  std::uint64_t lost = 0;
  std::uint64_t tiles_lost = 0;
  std::uint64_t refused = 0;
  std::optional<double> age_s;           // behind the newest input; none before its first map
  std::optional<double> clock_offset_s;  // against the other inputs; none until known
  std::string last_error;
};

struct MergeReport {
  std::string hostname;     // set once
  std::string config_file;  // set once
  std::string map_channel;  // set once
  DaemonState state = DaemonState::kRunning;
  double uptime_s = 0;
  std::uint64_t maps_published = 0;
  std::uint64_t publish_errors = 0;
  double max_age_s = 0;
  double latency_p50_ms = 0;
  double latency_p99_ms = 0;
  double latency_last_ms = 0;
  double merge_p50_ms = 0;
  double merge_p99_ms = 0;
  double clock_warning_s = 0;
  std::vector<MergeInputReport> inputs;
};

class MergeStatusPublisher {
 public:
  // `now_ns` (CLOCK_MONOTONIC) starts the rate window.
  MergeStatusPublisher(const std::string& status_channel, std::size_t inputs, std::int64_t now_ns);

  // Sends the status of `report` at `now_ns`, answering `request_id` (-1: the periodic status,
  // which also moves the rate window on). A failed publish is counted in errors() and added to
  // the publish_errors of every status after it.
  void publish(Bus& bus, const MergeReport& report, std::int64_t request_id, std::int64_t now_ns);
  std::uint64_t errors() const { return errors_; }
  const std::string& channel() const { return channel_; }
  // The message as last sent.
  const occmap::merge_status_t& last() const { return status_; }

 private:
  std::string channel_;
  RateWindow rates_;
  occmap::merge_status_t status_{};
  std::vector<std::uint8_t> buffer_;
  std::uint64_t errors_ = 0;
};

}  // namespace occmap
