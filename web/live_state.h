#pragma once
// What `occmap web` holds of the bus: the newest map (as the binary frame every browser is sent,
// and a short ring of recent maps for GET /map.png), the newest status of every daemon heard (as
// the JSON `occmap status --json` prints), and the newest zones and tracks (as JSON). Only the
// newest of each: nothing queues. One thread puts (BusFeed's, the LCM thread), any thread reads;
// what is handed out is shared and immutable, so that a reader holds no lock while it sends, and a
// put never waits for a reader.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "core/map_geometry.h"

namespace occmap::web {

using SharedBytes = std::shared_ptr<const std::vector<std::uint8_t>>;
using SharedText = std::shared_ptr<const std::string>;

// One map as received (the cells of a map_frame_t, or of its tiles put together).
struct HeldMap {
  std::int64_t seq = 0;
  std::int64_t utime = 0;       // capture time of its newest frame, us since the Unix epoch
  std::int64_t recv_utime = 0;  // when it was received here
  OccupancyMap map;
};

// A daemon heard on the status channels: a camera PC's occmapd (status_t) or a merge node
// (merge_status_t).
struct DaemonHeard {
  std::string hostname;
  std::string config_file;
  bool merge_node = false;
  SharedText status_json;     // formatStatusJson / formatMergeStatusJson, one line
  std::int64_t heard_ns = 0;  // CLOCK_MONOTONIC when its newest status came

  bool sameDaemon(const DaemonHeard& other) const {
    return hostname == other.hostname && merge_node == other.merge_node &&
           config_file == other.config_file;
  }
};

// A camera's newest preview (camera_preview_t, docs/daemon.md "Camera previews"), unpacked once
// on the LCM thread: what /camera/HOST/CAMERA.jpg, …/changed.png, …/cells.png and /coverage.png
// are made of.
struct HeldPreview {
  std::string hostname;
  std::string camera;
  std::int64_t utime = 0;  // capture time of the frame shown, us since the Unix epoch
  std::int64_t sequence = 0;
  int width = 0;  // the preview's size, pixels
  int height = 0;
  std::vector<std::uint8_t> jpeg;  // as the daemon sent it
  // One byte per preview pixel, row-major from the top: 1 changed.
  std::vector<std::uint8_t> changed;
  int map_width = 0;
  int map_height = 0;
  std::vector<std::uint8_t> coverage;  // one byte per map cell, row-major from row 0; 1 decided
  std::int64_t heard_ns = 0;           // CLOCK_MONOTONIC when it came

  std::size_t bytes() const { return jpeg.size() + changed.size() + coverage.size(); }
};

// A change counter per kind: a reader that kept the last it saw knows what is new.
struct LiveGenerations {
  std::uint64_t map = 0;
  std::uint64_t daemons = 0;
  std::uint64_t zones = 0;
  std::uint64_t tracks = 0;
  std::uint64_t previews = 0;
};

// What was heard, counted since the start.
struct LiveCounters {
  std::uint64_t maps = 0;
  std::uint64_t statuses = 0;
  std::uint64_t zones = 0;
  std::uint64_t tracks = 0;
  std::uint64_t previews = 0;
  std::uint64_t refused = 0;  // messages that did not decode, on any channel
  std::string last_refusal;   // "CHANNEL: why"
};

class LiveState {
 public:
  // Maps kept for GET /map.png?seq=N: about a second at 30 maps a second.
  static constexpr std::size_t kRecentMaps = 30;
  // The most daemons held (anyone on the segment can publish statuses under any name).
  static constexpr std::size_t kMaxDaemons = 64;
  // A daemon not heard for this long is forgotten.
  static constexpr std::int64_t kForgetDaemonNs = 60'000'000'000;
  // The most cameras whose previews are held; a preview older than kForgetDaemonNs is forgotten.
  static constexpr std::size_t kMaxPreviews = 256;
  // The most bytes all previews held may take. A message of a few hundred bytes can declare a map
  // of 8192 x 8192 cells whose coverage zstd unpacks to 64 MiB (found by fuzz/camera_preview):
  // without a budget, made-up camera names could make this server hold gigabytes. 32 cameras of
  // 2048 x 2048 maps take 128 MiB.
  static constexpr std::size_t kMaxPreviewBytes = std::size_t{256} << 20;
  // A preview's coverage is held only for maps of at most this many cells (4096 x 4096); a larger
  // map's previews are shown without their cells.
  static constexpr std::size_t kMaxCoverageCells = std::size_t{4096} * 4096;

  LiveState() = default;
  LiveState(const LiveState&) = delete;
  LiveState& operator=(const LiveState&) = delete;

  // Called after every put, on the putting thread, outside the lock: the server's wake-up (it
  // must not block). Set it before anything is put.
  void setOnChange(std::function<void()> on_change) { on_change_ = std::move(on_change); }

  // The putting thread's side.
  void putMap(std::shared_ptr<const HeldMap> map, SharedBytes frame);
  // Replaces the status of the same daemon (DaemonHeard::sameDaemon), or adds it.
  void putDaemon(DaemonHeard daemon);
  void putZones(SharedText json);
  void putTracks(SharedText json);
  // Replaces the preview of the same host and camera, or adds it.
  void putPreview(std::shared_ptr<const HeldPreview> preview);
  void countRefused(std::string what);

  // Any thread.
  LiveGenerations generations() const;
  SharedBytes newestMapFrame() const;
  std::shared_ptr<const HeldMap> newestMap() const;
  // The map numbered `seq` while it is among the last kRecentMaps, or nullptr.
  std::shared_ptr<const HeldMap> recentMap(std::int64_t seq) const;
  // Every daemon heard within kForgetDaemonNs of `now_ns`, sorted by host (a camera PC before a
  // merge node of the same host), then by config file.
  std::vector<DaemonHeard> daemons(std::int64_t now_ns) const;
  SharedText zones() const;
  SharedText tracks() const;
  // The newest preview of `camera` on `hostname`, or nullptr.
  std::shared_ptr<const HeldPreview> preview(const std::string& hostname,
                                             const std::string& camera) const;
  // Every camera's newest preview heard within kForgetDaemonNs of `now_ns`, sorted by host, then
  // camera.
  std::vector<std::shared_ptr<const HeldPreview>> previews(std::int64_t now_ns) const;
  LiveCounters counters() const;

  // Browsers watching (the server's count): while there is one, the bus feed asks for previews.
  void setViewers(std::size_t viewers) { viewers_.store(viewers, std::memory_order_relaxed); }
  std::size_t viewers() const { return viewers_.load(std::memory_order_relaxed); }

 private:
  void changed() const {
    if (on_change_) on_change_();
  }

  std::function<void()> on_change_;
  mutable std::mutex mutex_;
  LiveGenerations generations_;
  LiveCounters counters_;
  SharedBytes map_frame_;
  std::deque<std::shared_ptr<const HeldMap>> recent_;  // oldest first
  std::vector<DaemonHeard> daemons_;
  SharedText zones_;
  SharedText tracks_;
  std::vector<std::shared_ptr<const HeldPreview>> previews_;
  std::atomic<std::size_t> viewers_{0};
};

}  // namespace occmap::web
