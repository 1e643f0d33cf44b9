#pragma once
// The people, tracks and zones on the bus (issue 14, docs/detection.md): tracks_t and zones_t,
// on channels named after the map's, and their decoders for messages from the network. Anyone on
// the segment can publish on those channels, so a message is walked field by field and every count
// checked against the bytes received before LCM's generated decoder sees it (wire_reader.h). No
// exception leaves the decoders.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include <occmap/tracks_t.hpp>
#include <occmap/zones_t.hpp>

namespace occmap {

// Where occmapd publishes tracks_t: the map channel's name + "_TRACKS" (OCCMAP_MAP_TRACKS).
std::string tracksChannel(const std::string& map_channel);
// Where occmapd publishes zones_t, right after each map: the map channel's name + "_ZONES"
// (OCCMAP_MAP_ZONES).
std::string zonesChannel(const std::string& map_channel);

// A tracks_t, or nothing when the bytes are not exactly one; then `error`, if given, says why.
std::optional<occmap::tracks_t> decodeTracks(const std::uint8_t* data, std::size_t size,
                                             std::string* error = nullptr);
// A zones_t, or nothing when the bytes are not exactly one; then `error`, if given, says why.
std::optional<occmap::zones_t> decodeZones(const std::uint8_t* data, std::size_t size,
                                           std::string* error = nullptr);

}  // namespace occmap
