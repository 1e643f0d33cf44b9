#pragma once
// The LCM side of `occmap web`: one thread that listens to the bus as `occmap view` and
// `occmap status` do (maps whole or in tiles, zones_t, tracks_t, status_t and merge_status_t with
// their control, lighting and view companions), asks every daemon for its status about once a
// second (status_request_t, as `occmap status`; at once, too, when a map says a camera changed
// state), and puts the newest of each into a LiveState. Nothing a browser does reaches this
// thread: it only takes a short lock to swap what it heard in, and the server is woken, never
// waited for.

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <occmap/camera_preview_t.hpp>
#include <occmap/control_status_t.hpp>
#include <occmap/lighting_status_t.hpp>
#include <occmap/merge_status_t.hpp>
#include <occmap/status_t.hpp>
#include <occmap/tracks_t.hpp>
#include <occmap/view_status_t.hpp>
#include <occmap/zones_t.hpp>

#include "transport/lcm_bus.h"
#include "transport/map_codec.h"
#include "transport/map_receiver.h"
#include "web/live_state.h"

namespace occmap::web {

struct BusFeedOptions {
  std::string lcm_url;
  std::string map_channel;  // maps; tiles, zones and tracks on its name + _TILES, _ZONES, _TRACKS
  std::string status_channel;  // status_t; requests, companions and merge nodes on its name + …
  double status_request_interval_s = 1.0;
  // While a browser watches (LiveState::viewers), previews of every camera are asked for this
  // often: occmapd sends them for 10 s after the last request, so they stop within about 10 s of
  // the last browser leaving.
  double preview_request_interval_s = 3.0;
};

class BusFeed {
 public:
  BusFeed(BusFeedOptions options, LiveState& state);
  ~BusFeed();
  BusFeed(const BusFeed&) = delete;
  BusFeed& operator=(const BusFeed&) = delete;

  // Opens LCM and subscribes: "" when listening, else what went wrong (in words, for the user).
  std::string open();
  // Starts the thread (after open()); stop() ends it (also done by the destructor).
  void start();
  void stop();

  const BusFeedOptions& options() const { return options_; }

 private:
  // The newest message of one kind from each of a few dozen hosts.
  template <typename Message>
  class NewestByHost {
   public:
    const Message* of(const std::string& hostname) const;
    void keep(Message&& message);

   private:
    std::vector<Message> kept_;
  };

  void run();
  void onMap(const DecodedMap& map, std::int64_t recv_utime);
  void onStatus(occmap::status_t&& status);
  void onMergeStatus(occmap::merge_status_t&& status);
  void onPreview(const occmap::camera_preview_t& preview);
  // A companion (control, lighting, view) or the zones or tracks of `hostname` came: its daemons'
  // JSON is made again.
  void refreshHost(const std::string& hostname);
  void publishDaemon(std::size_t index);
  void requestStatus();
  void requestPreviews();
  void refuse(const std::string& channel, const std::string& why);

  BusFeedOptions options_;
  LiveState& state_;
  std::unique_ptr<LcmBus> bus_;
  std::unique_ptr<MapReceiver> maps_;
  std::thread thread_;
  std::atomic<bool> stopping_{false};

  // The LCM thread's own (and open()'s, before it starts).
  struct Daemon {
    std::optional<occmap::status_t> camera_pc;
    std::optional<occmap::merge_status_t> merge_node;
    std::int64_t heard_ns = 0;
    std::int64_t first_heard_ns = 0;
  };
  std::vector<Daemon> daemons_;
  NewestByHost<occmap::control_status_t> controls_;
  NewestByHost<occmap::lighting_status_t> lightings_;
  NewestByHost<occmap::view_status_t> views_;
  NewestByHost<occmap::zones_t> zones_;
  NewestByHost<occmap::tracks_t> tracks_;
  std::vector<std::pair<std::string, CameraState>> map_cameras_;  // in the newest map
  std::int64_t request_id_ = 0;
  std::int64_t started_ns_ = 0;
  std::int64_t next_request_ns_ = 0;
  std::int64_t last_request_ns_ = 0;
  bool prompt_request_ = false;
  std::int64_t next_preview_request_ns_ = 0;  // 0: none asked for (no browser watching)
  std::vector<std::uint8_t> request_bytes_;
};

}  // namespace occmap::web
