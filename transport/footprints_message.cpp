#include "transport/footprints_message.h"

#include "transport/wire_reader.h"

namespace occmap {
namespace {

// The head both types share: fingerprint, utime, seq, hostname.
const char* headError(WireReader& in, std::int64_t hash, const char* other_fingerprint) {
  std::int64_t fingerprint = 0;
  if (!in.read(fingerprint)) return "too short for an LCM message";
  if (fingerprint != hash) return other_fingerprint;
  if (!in.skip(8 + 8)) return "truncated in utime or seq";
  const char* text = nullptr;
  std::size_t length = 0;
  if (!in.readString(text, length)) return "hostname is not a string that fits";
  return "";
}

// A count, then that many elements of `bytes` each (at most 32767 of them: no overflow).
bool skipArray(WireReader& in, std::size_t bytes) {
  std::int16_t count = 0;
  return in.read(count) && count >= 0 && in.skip(static_cast<std::size_t>(count) * bytes);
}

// lcmtypes/tracks_t.lcm: footprint_t is 5 doubles, track_t an int32 and 7 doubles.
const char* tracksLayoutError(const std::uint8_t* data, std::size_t size) {
  WireReader in(data, size);
  if (const char* why =
          headError(in, occmap::tracks_t::getHash(), "not an occmap.tracks_t (fingerprint)");
      *why != '\0') {
    return why;
  }
  if (!skipArray(in, 5 * 8)) return "num_footprints is negative or the footprints are truncated";
  if (!skipArray(in, 4 + 7 * 8)) return "num_tracks is negative or the tracks are truncated";
  if (in.remaining() != 0) return "bytes left over: the counts do not add up to the size";
  return "";
}

// lcmtypes/zones_t.lcm and zone_t.lcm.
const char* zonesLayoutError(const std::uint8_t* data, std::size_t size) {
  WireReader in(data, size);
  if (const char* why =
          headError(in, occmap::zones_t::getHash(), "not an occmap.zones_t (fingerprint)");
      *why != '\0') {
    return why;
  }
  std::int16_t zones = 0;
  if (!in.read(zones)) return "truncated before num_zones";
  if (zones < 0) return "num_zones is negative";
  for (int k = 0; k < zones; ++k) {
    const char* text = nullptr;
    std::size_t length = 0;
    if (!in.readString(text, length)) return "a zone's name is not a string that fits";
    // state, state_s, cells, occupied_cells, unseen_cells
    if (!in.skip(1 + 8 + 3 * 4)) return "truncated in a zone's figures";
    std::int16_t corners = 0;
    if (!in.read(corners)) return "truncated before a zone's num_corners";
    if (corners < 0) return "a zone's num_corners is negative";
    if (!in.skip(static_cast<std::size_t>(corners) * 2 * 8))
      return "a zone's corners are truncated";
  }
  if (in.remaining() != 0) return "bytes left over: the counts do not add up to the size";
  return "";
}

}  // namespace

std::string tracksChannel(const std::string& map_channel) { return map_channel + "_TRACKS"; }
std::string zonesChannel(const std::string& map_channel) { return map_channel + "_ZONES"; }

std::optional<occmap::tracks_t> decodeTracks(const std::uint8_t* data, std::size_t size,
                                             std::string* error) {
  return decodeWalked<occmap::tracks_t>(data, size, error, tracksLayoutError);
}

std::optional<occmap::zones_t> decodeZones(const std::uint8_t* data, std::size_t size,
                                           std::string* error) {
  return decodeWalked<occmap::zones_t>(data, size, error, zonesLayoutError);
}

}  // namespace occmap
