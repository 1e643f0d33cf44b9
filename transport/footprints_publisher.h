#pragma once
// The people, tracks and zones onto the bus (transport/footprints_message.h): zones_t right after
// each map, with its seq and utime; tracks_t whenever the detector is done with a map. The messages
// are filled in place: once their vectors have their size, publishing allocates nothing.

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <occmap/tracks_t.hpp>
#include <occmap/zones_t.hpp>

#include "core/footprints.h"
#include "core/tracker.h"
#include "core/zones.h"
#include "transport/bus.h"

namespace occmap {

class FootprintsPublisher {
 public:
  // `zones` as in the config.
  FootprintsPublisher(const std::string& map_channel, std::string hostname,
                      std::span<const ZoneSpec> zones);

  // The zones' states on the map numbered `seq`, made at `time_s` (the times the zones were given).
  // False when it could not be sent (counted in errors()). Nothing is sent when there are no zones.
  bool publishZones(Bus& bus, std::int64_t seq, std::int64_t utime,
                    std::span<const ZoneStatus> zones, double time_s);
  // What the detector found on the map numbered `seq` (-1: a map never sent), and the tracks.
  bool publishTracks(Bus& bus, std::int64_t seq, std::int64_t utime,
                     std::span<const Detection> footprints, std::span<const Track> tracks);

  std::uint64_t errors() const { return errors_; }

 private:
  bool send(Bus& bus, const std::string& channel, const auto& message);

  std::string tracks_channel_;
  std::string zones_channel_;
  occmap::tracks_t tracks_{};
  occmap::zones_t zones_{};
  std::vector<std::uint8_t> buffer_;
  std::uint64_t errors_ = 0;
};

}  // namespace occmap
