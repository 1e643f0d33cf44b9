// zones: a zones_t as `occmap status` reads it (heard on the map channel's name + "_ZONES" while it
// waits for the daemon's answer, from the daemon or from anyone on the network segment) and prints
// it: a line per zone in the table, and the "zones" array of the JSON.
#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <occmap/status_t.hpp>
#include <occmap/zones_t.hpp>

#include "fuzz/fuzz_target.h"
#include "transport/footprints_message.h"
#include "transport/status_text.h"

namespace occmap::fuzz {

bool fuzzZones(Input input) {
  // As tools/status_command.cpp decodes it.
  std::string error;
  const std::optional<occmap::zones_t> decoded = decodeZones(input.data(), input.size(), &error);
  if (!decoded) {
    require(!error.empty(), "a refused zones_t says why");
    return false;  // ignored: the status is printed without it
  }
  const occmap::zones_t& zones = *decoded;
  require(zones.num_zones >= 0 && zones.zones.size() == static_cast<std::size_t>(zones.num_zones),
          "an accepted zones_t has num_zones zones");
  for (const occmap::zone_t& zone : zones.zones) {
    require(zone.num_corners >= 0 &&
                zone.corner_x_m.size() == static_cast<std::size_t>(zone.num_corners) &&
                zone.corner_y_m.size() == static_cast<std::size_t>(zone.num_corners),
            "an accepted zone has num_corners of each corner coordinate");
  }
  // Accepted means exactly one zones_t: encoded again, it is the same bytes.
  std::vector<std::uint8_t> again(static_cast<std::size_t>(zones.getEncodedSize()));
  require(zones.encode(again.data(), 0, static_cast<int>(again.size())) ==
                  static_cast<int>(again.size()) &&
              std::equal(again.begin(), again.end(), input.begin(), input.end()),
          "an accepted zones_t encodes back to the bytes received");

  // Printed after a status (here an empty one), with no tracks_t heard. The table goes to the
  // user's terminal: no escape sequences, no carriage returns; a line per zone (one saying there
  // are none when there are none) and one for the missing tracks, at the table's end.
  const ZonesAndTracks heard{&zones, nullptr, 0.5};
  const std::string section = formatZonesAndTracks(heard);
  for (const char c : section) {
    const auto byte = static_cast<unsigned char>(c);
    require(c == '\n' || (byte >= 0x20 && byte != 0x7f),
            "the zones' and tracks' lines hold no control characters but line ends");
  }
  require(static_cast<std::size_t>(std::count(section.begin(), section.end(), '\n')) ==
                  std::max<std::size_t>(zones.zones.size(), 1) + 1 &&
              section.back() == '\n',
          "a line for each zone and one for the tracks not heard");
  const occmap::status_t status{};
  const std::string table = formatStatusTable(status, nullptr, nullptr, nullptr, &heard);
  require(table.size() >= section.size() &&
              table.compare(table.size() - section.size(), section.size(), section) == 0,
          "the status table ends with the zones' and tracks' lines");
  // What --json prints is read by programs and may be printed on a terminal: valid JSON,
  // printable ASCII only (numbers that are not finite come out as null).
  const std::string json = formatStatusJson(status, nullptr, nullptr, nullptr, &heard);
  require(nlohmann::json::accept(json), "occmap status --json prints valid JSON with a zones_t");
  require(std::all_of(json.begin(), json.end(), [](char c) { return c >= 0x20 && c < 0x7f; }),
          "occmap status --json prints printable ASCII only");
  const nlohmann::json parsed = nlohmann::json::parse(json);
  require(parsed.at("zones").size() == zones.zones.size() && parsed.at("tracks").is_null(),
          "the JSON's \"zones\" holds every zone, \"tracks\" is null");
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzZones)
