#pragma once
// What `occmap view` hears of the people, tracks and zones occmapd finds on its maps
// (transport/footprints_message.h): the last few zones_t and tracks_t, decoded and counted, matched
// to the maps they belong to, drawn over those maps (tools/footprint_pictures.h) and put in words.

#include <cstddef>
#include <cstdint>
#include <deque>
#include <string>

#include <occmap/tracks_t.hpp>
#include <occmap/zones_t.hpp>
#include <opencv2/core.hpp>

#include "core/map_geometry.h"

namespace occmap::tools {

// Messages of one type heard.
struct MessageCount {
  std::int64_t received = 0, undecodable = 0;
  bool any() const { return received + undecodable > 0; }
};

class FootprintsHeard {
 public:
  // Decodes and keeps one message; false, with `error` saying why, for bytes that are not one.
  bool takeZones(const std::uint8_t* data, std::size_t size, std::string& error);
  bool takeTracks(const std::uint8_t* data, std::size_t size, std::string& error);
  const MessageCount& zonesCount() const { return zones_count_; }
  const MessageCount& tracksCount() const { return tracks_count_; }

  // The zones on the map numbered `seq` (zones_t are sent right after their map), or null.
  const occmap::zones_t* zonesOf(std::int64_t seq) const;
  // The newest tracks found on the map (seq, utime) or on an earlier one (the detector lags the
  // maps a little, and may skip some): seq no greater or, for a tracks_t whose map was never sent
  // (seq -1), utime no later. Null when there are none, or when they are more than a second older
  // than the map: then the detector has stopped, and old tracks would be drawn as if current.
  const occmap::tracks_t* tracksFor(std::int64_t seq, std::int64_t utime) const;

  // Draws the zones and tracks that belong to the map (seq, utime) over its floor plan.
  void draw(cv::Mat& plan, const MapGeometry& map, int pixels_per_cell, std::int64_t seq,
            std::int64_t utime) const;

  // "  tracks 2  zones: robot-cell occupied, door free" from the newest heard (for the line each
  // second), or "" before any.
  std::string newestText() const;
  // What draw() draws over the map (seq, utime): "; with its zones; with the tracks found on map
  // N", or "".
  std::string drawnText(std::int64_t seq, std::int64_t utime) const;
  // "; zones_t: received Z, undecodable U; tracks_t: received T, undecodable V" (for the summary),
  // or "" when nothing was heard on either channel.
  std::string countsText() const;

 private:
  // The last few of each, oldest first: a message taken out of order still finds its map.
  static constexpr std::size_t kKept = 4;
  std::deque<occmap::zones_t> zones_;
  std::deque<occmap::tracks_t> tracks_;
  MessageCount zones_count_, tracks_count_;
};

}  // namespace occmap::tools
