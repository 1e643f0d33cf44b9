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
#include "fuzz/zones_and_tracks_printed.h"
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

  // Printed after a status, with no tracks_t heard (fuzz/zones_and_tracks_printed.h).
  const ZonesAndTracks heard{&zones, nullptr, 0.5};
  const nlohmann::json parsed =
      checkZonesAndTracksPrinted(heard, std::max<std::size_t>(zones.zones.size(), 1) + 1);
  require(parsed.at("zones").size() == zones.zones.size() && parsed.at("tracks").is_null(),
          "the JSON's \"zones\" holds every zone, \"tracks\" is null");
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzZones)
