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

  // Printed after a status (here an empty one), with no zones_t heard. The table goes to the
  // user's terminal: no escape sequences, no carriage returns; a line for the missing zones and
  // one for the tracks, at the table's end.
  const ZonesAndTracks heard{nullptr, &tracks, 0.5};
  const std::string section = formatZonesAndTracks(heard);
  for (const char c : section) {
    const auto byte = static_cast<unsigned char>(c);
    require(c == '\n' || (byte >= 0x20 && byte != 0x7f),
            "the zones' and tracks' lines hold no control characters but line ends");
  }
  require(std::count(section.begin(), section.end(), '\n') == 2 && section.back() == '\n',
          "a line for the zones not heard and one for the tracks");
  const occmap::status_t status{};
  const std::string table = formatStatusTable(status, nullptr, nullptr, nullptr, &heard);
  require(table.size() >= section.size() &&
              table.compare(table.size() - section.size(), section.size(), section) == 0,
          "the status table ends with the zones' and tracks' lines");
  // What --json prints is read by programs and may be printed on a terminal: valid JSON,
  // printable ASCII only (numbers that are not finite come out as null).
  const std::string json = formatStatusJson(status, nullptr, nullptr, nullptr, &heard);
  require(nlohmann::json::accept(json), "occmap status --json prints valid JSON with a tracks_t");
  require(std::all_of(json.begin(), json.end(), [](char c) { return c >= 0x20 && c < 0x7f; }),
          "occmap status --json prints printable ASCII only");
  const nlohmann::json parsed = nlohmann::json::parse(json);
  require(parsed.at("zones").is_null() &&
              parsed.at("tracks").at("tracks").size() == tracks.tracks.size() &&
              parsed.at("tracks").at("footprints").size() == tracks.footprints.size(),
          "the JSON's \"tracks\" holds every track and footprint, \"zones\" is null");
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzTracks)
