// tracks: a tracks_t as `occmap status` reads it (heard on the map channel's name + "_TRACKS" while
// it waits for the daemon's answer, from the daemon or from anyone on the network segment) and
// prints it: the tracks' line of the table, and the "tracks" object of the JSON.
#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <occmap/status_t.hpp>
#include <occmap/tracks_t.hpp>

#include "fuzz/fuzz_target.h"
#include "fuzz/zones_and_tracks_printed.h"
#include "transport/footprints_message.h"
#include "transport/status_text.h"

namespace occmap::fuzz {

bool fuzzTracks(Input input) {
  // As tools/status_command.cpp decodes it.
  std::string error;
  const std::optional<occmap::tracks_t> decoded = decodeTracks(input.data(), input.size(), &error);
  if (!decoded) {
    require(!error.empty(), "a refused tracks_t says why");
    return false;  // ignored: the status is printed without it
  }
  const occmap::tracks_t& tracks = *decoded;
  require(tracks.num_footprints >= 0 &&
              tracks.footprints.size() == static_cast<std::size_t>(tracks.num_footprints) &&
              tracks.num_tracks >= 0 &&
              tracks.tracks.size() == static_cast<std::size_t>(tracks.num_tracks),
          "an accepted tracks_t has num_footprints footprints and num_tracks tracks");
  // Accepted means exactly one tracks_t: encoded again, it is the same bytes.
  std::vector<std::uint8_t> again(static_cast<std::size_t>(tracks.getEncodedSize()));
  require(tracks.encode(again.data(), 0, static_cast<int>(again.size())) ==
                  static_cast<int>(again.size()) &&
              std::equal(again.begin(), again.end(), input.begin(), input.end()),
          "an accepted tracks_t encodes back to the bytes received");

  // Printed after a status, with no zones_t heard (fuzz/zones_and_tracks_printed.h).
  const ZonesAndTracks heard{nullptr, &tracks, 0.5};
  const nlohmann::json parsed = checkZonesAndTracksPrinted(heard, 2);
  require(parsed.at("zones").is_null() &&
              parsed.at("tracks").at("tracks").size() == tracks.tracks.size() &&
              parsed.at("tracks").at("footprints").size() == tracks.footprints.size(),
          "the JSON's \"tracks\" holds every track and footprint, \"zones\" is null");
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzTracks)
