#include "transport/map_receiver.h"

#include <utility>

namespace occmap {

MapReceiver::MapReceiver(Bus& bus, std::string map_channel, Handler handler, RefusalHandler refused)
    : map_channel_(std::move(map_channel)),
      tile_channel_(tilesChannel(map_channel_)),
      handler_(std::move(handler)),
      refused_(std::move(refused)),
      assembler_([this](const DecodedMap& map, const MapTiles& tiles) {
        tiles_of_map_ = tiles;
        ++maps_;
        if (handler_) handler_(map, tiles.recv_utime);
      }) {
  subscribed_ =
      bus.subscribe(map_channel_,
                    [this](const std::uint8_t* data, std::size_t size, std::int64_t recv_utime) {
                      onMap(data, size, recv_utime);
                    }) &&
      bus.subscribeBursts(tile_channel_, kTileQueueDepth,
                          [this](const std::uint8_t* data, std::size_t size,
                                 std::int64_t recv_utime) { onTile(data, size, recv_utime); });
}

void MapReceiver::onMap(const std::uint8_t* data, std::size_t size, std::int64_t recv_utime) {
  const DecodedMap& map = decoder_.decode(data, size);
  if (!map.ok()) {
    ++undecodable_;
    refuse(map_channel_, size, map.error);
    return;
  }
  tiles_of_map_ = MapTiles{0, 0, recv_utime};
  ++maps_;
  ++whole_maps_;
  if (handler_) handler_(map, recv_utime);
}

void MapReceiver::onTile(const std::uint8_t* data, std::size_t size, std::int64_t recv_utime) {
  if (!assembler_.take(data, size, recv_utime)) refuse(tile_channel_, size, assembler_.lastError());
}

void MapReceiver::refuse(const std::string& channel, std::size_t size, const std::string& why) {
  last_error_ = channel + ": " + why;
  if (refused_) refused_(channel, size, why);
}

MapReceiverCounters MapReceiver::counters() const {
  MapReceiverCounters counters;
  counters.maps = maps_;
  counters.whole_maps = whole_maps_;
  counters.undecodable = undecodable_;
  counters.tiles = assembler_.counters();
  counters.last_error = last_error_;
  return counters;
}

}  // namespace occmap
