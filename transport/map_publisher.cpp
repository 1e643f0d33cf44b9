#include "transport/map_publisher.h"

#include <cerrno>
#include <cstring>

#include "base/clock.h"
#include "base/log.h"

namespace occmap {

MapPublisher::MapPublisher(const MapGeometry& geometry,
                           const std::vector<std::string>& camera_names, MapEncoding encoding,
                           std::string channel, std::string where, MapMessages messages)
    : channel_(messages == MapMessages::kTiles ? tilesChannel(channel) : std::move(channel)),
      where_(std::move(where)) {
  if (messages == MapMessages::kTiles) {
    tiles_ = std::make_unique<MapTileEncoder>(geometry, camera_names, encoding);
  } else {
    whole_ = std::make_unique<MapEncoder>(geometry, camera_names, encoding);
  }
}

MapPublisher::~MapPublisher() = default;

bool MapPublisher::publish(Bus& bus, MapFrame& map) {
  map.seq = next_seq_++;
  const char* why = "";
  std::uint64_t failed = 0;
  std::uint64_t messages = 1;
  if (whole_) {
    const std::span<const std::uint8_t> message = whole_->encode(map);
    if (message.empty()) {
      why = whole_->lastError();
      failed = 1;
    } else if (!bus.publish(channel_, message)) {
      why = std::strerror(errno);  // what the send left
      failed = 1;
    }
  } else {
    // Every tile is tried, whatever happened to the one before: a tile that went out is a part of
    // the map its subscribers have.
    const int count = tiles_->tileCount();
    messages = static_cast<std::uint64_t>(count);
    for (int index = 0; index < count; ++index) {
      const std::span<const std::uint8_t> message = tiles_->encode(map, index);
      if (message.empty()) {
        why = tiles_->lastError();
        ++failed;
      } else if (!bus.publish(channel_, message)) {
        why = std::strerror(errno);
        ++failed;
      }
    }
  }
  if (failed == 0) {
    // Measured when the send has returned: the daemon's whole part of the frame's way.
    if (map.newest_arrival_ns != 0) latency_.record(monotonicNanoseconds() - map.newest_arrival_ns);
    published_.fetch_add(1, std::memory_order_relaxed);
    return true;
  }
  errors_.fetch_add(failed, std::memory_order_relaxed);
  warn(why, failed, messages);
  return false;
}

void MapPublisher::warn(const char* why, std::uint64_t failed, std::uint64_t of) {
  std::uint64_t suppressed = 0;
  if (!warnings_.allow(suppressed)) return;
  if (whole_) {
    logLine(LogLevel::kWarning,
            "a map could not be sent on %s (%s; %llu more failures since): is the network "
            "down? Maps go out again as soon as it is back",
            where_.c_str(), why, static_cast<unsigned long long>(suppressed));
  } else {
    logLine(LogLevel::kWarning,
            "%llu of the %llu tiles of a map could not be sent on %s (%s; %llu more maps with "
            "failures since): their cells are unseen to subscribers. Is the network down? Tiles "
            "go out again as soon as it is back",
            static_cast<unsigned long long>(failed), static_cast<unsigned long long>(of),
            where_.c_str(), why, static_cast<unsigned long long>(suppressed));
  }
}

}  // namespace occmap
