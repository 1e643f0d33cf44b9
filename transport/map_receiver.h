#pragma once
// What a subscriber of occmapd's maps uses: the maps of one map channel, whichever way they come,
// whole (map_frame_t on the channel itself) or in tiles (map_tile_t on its name + "_TILES",
// transport/map_tiles.h), handed to one callback as DecodedMaps, with what was refused and lost
// counted. `occmap view` and the merge node read maps through it.
//
// Threads: as its Bus, used from the one thread that runs the bus's handlers.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

#include "transport/bus.h"
#include "transport/map_codec.h"
#include "transport/map_tiles.h"

namespace occmap {

// What a MapReceiver has seen.
struct MapReceiverCounters {
  std::uint64_t maps = 0;         // handed to the handler, whole or put together from tiles
  std::uint64_t whole_maps = 0;   // of them, map_frame_t
  std::uint64_t undecodable = 0;  // map_frame_t messages refused
  MapTileCounters tiles;          // the tiles channel's (refused tiles: tiles.tiles_refused)
  std::string last_error;         // the last refusal on either channel: "CHANNEL: why"
};

class MapReceiver {
 public:
  // A map, valid during the call only, and when its last message was received (us since the
  // Unix epoch). tilesOfMap() says how it came while the handler runs.
  using Handler = std::function<void(const DecodedMap& map, std::int64_t recv_utime)>;
  // A message refused: its channel, its size and why (for a program that says so).
  using RefusalHandler =
      std::function<void(const std::string& channel, std::size_t size, const std::string& why)>;

  // Tiles that may wait for the program's handleTimeout() before any is dropped: a dozen
  // 2048 x 2048 maps' (81 tiles each), come back to back. Measured through LCM on a link that lost
  // nothing: with LCM's default depth, 30, 334 to 561 of 1620 such tiles were dropped; with this,
  // none (tiled_map_network_test).
  static constexpr std::size_t kTileQueueDepth = 1024;

  // Subscribes on `bus` to `map_channel` and tilesChannel(map_channel). Check subscribed().
  MapReceiver(Bus& bus, std::string map_channel, Handler handler, RefusalHandler refused = {});
  MapReceiver(const MapReceiver&) = delete;
  MapReceiver& operator=(const MapReceiver&) = delete;

  // Whether both subscriptions were made.
  bool subscribed() const { return subscribed_; }
  const std::string& mapChannel() const { return map_channel_; }
  const std::string& tileChannel() const { return tile_channel_; }

  // While the handler runs: the tiles of the map it was given (count 0 for a whole map_frame_t;
  // missing: tiles that never came, their cells unseen).
  const MapTiles& tilesOfMap() const { return tiles_of_map_; }

  // Gives out a tiled map still waiting for tiles, its missing tiles unseen (when the stream has
  // stopped: a tiled map is otherwise given out incomplete only once a newer map's tile comes).
  void flush() { assembler_.flush(); }

  MapReceiverCounters counters() const;

 private:
  void onMap(const std::uint8_t* data, std::size_t size, std::int64_t recv_utime);
  void onTile(const std::uint8_t* data, std::size_t size, std::int64_t recv_utime);
  void refuse(const std::string& channel, std::size_t size, const std::string& why);

  std::string map_channel_;
  std::string tile_channel_;
  Handler handler_;
  RefusalHandler refused_;
  MapDecoder decoder_;
  MapTileAssembler assembler_;
  MapTiles tiles_of_map_;
  std::uint64_t maps_ = 0;
  std::uint64_t whole_maps_ = 0;
  std::uint64_t undecodable_ = 0;
  std::string last_error_;
  bool subscribed_ = false;
};

}  // namespace occmap
