#pragma once
// The fusion's maps onto the bus: each numbered as it is sent (so a gap a subscriber sees is a map
// lost on the way), encoded into one reused buffer and published, whole (map_frame_t on the map
// channel, map_codec.h) or in tiles (map_tile_t on the channel's name + "_TILES", map_tiles.h);
// what failed is counted and said now and then. On the publisher thread's hot path: allocates
// nothing.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "base/rate_limit.h"
#include "base/time_histogram.h"
#include "core/map_frame.h"
#include "transport/bus.h"
#include "transport/map_codec.h"
#include "transport/map_tiles.h"

namespace occmap {

// How maps go out (the config's transport.tiles).
enum class MapMessages : std::uint8_t {
  kWhole,  // each map one map_frame_t on the map channel (LCM fragments it past one datagram)
  kTiles,  // each map as map_tile_t tiles of at most 60 KiB on the map channel + "_TILES"
};

class MapPublisher {
 public:
  // `channel` is the map channel (tiles go on tilesChannel(channel)); `where` names the bus in
  // warnings (the LCM URL).
  MapPublisher(const MapGeometry& geometry, const std::vector<std::string>& camera_names,
               MapEncoding encoding, std::string channel, std::string where,
               MapMessages messages = MapMessages::kWhole);
  ~MapPublisher();

  // Numbers, encodes and sends `map`: one message, or every tile of it. False when anything could
  // not be encoded or sent: each message that failed (the whole map, or each tile) is counted in
  // errors() and said at most every ten seconds; a tiled map whose other tiles went out is still
  // sent, its subscribers seeing the failed tiles' cells as unseen.
  bool publish(Bus& bus, MapFrame& map);

  MapMessages messages() const { return tiles_ ? MapMessages::kTiles : MapMessages::kWhole; }

  // Any thread. published(): maps every message of which was sent. errors(): messages that could
  // not be encoded or sent (maps, or tiles when tiled: each failed tile is one error, so that a
  // map losing three tiles is three, not none).
  std::uint64_t published() const { return published_.load(std::memory_order_relaxed); }
  std::uint64_t errors() const { return errors_.load(std::memory_order_relaxed); }
  // From the arrival of a map's newest frame to the return of its publish: what the daemon adds
  // to a frame's way to the network.
  const TimeHistogram& latency() const { return latency_; }

 private:
  void warn(const char* why, std::uint64_t failed, std::uint64_t of);

  std::unique_ptr<MapEncoder> whole_;      // kWhole
  std::unique_ptr<MapTileEncoder> tiles_;  // kTiles
  std::string channel_;
  std::string where_;
  std::int64_t next_seq_ = 0;
  RateLimit warnings_{std::chrono::seconds(10)};
  TimeHistogram latency_;
  std::atomic<std::uint64_t> published_{0};
  std::atomic<std::uint64_t> errors_{0};
};

}  // namespace occmap
