// The zones' lines of `occmap status` (transport/status_text.h): a zone that occmapd calls unseen
// while some of its cells are occupied says why (core/hidden_floor.h).
#include "transport/status_text.h"

#include <string>

#include <gtest/gtest.h>

namespace occmap {
namespace {

occmap::zone_t zone(const char* name, std::int8_t state, std::int32_t occupied,
                    std::int32_t unseen) {
  occmap::zone_t z{};
  z.name = name;
  z.state = state;
  z.state_s = 2.1;
  z.cells = 20000;
  z.occupied_cells = occupied;
  z.unseen_cells = unseen;
  return z;
}

TEST(StatusText, AnUnseenZoneWithOccupiedCellsSaysTheyAreFloorHiddenBehindPeopleFound) {
  occmap::zones_t zones{};
  zones.zones = {zone("walkway", occmap::zone_t::UNSEEN, 1373, 0),
                 zone("door", occmap::zone_t::UNSEEN, 0, 12),
                 zone("robot-cell", occmap::zone_t::OCCUPIED, 447, 0)};
  zones.num_zones = 3;
  ZonesAndTracks heard;
  heard.zones = &zones;
  const std::string text = formatZonesAndTracks(heard);
  EXPECT_NE(text.find("zone walkway     unseen for 2.1 s (1373 of 20000 cells occupied, all floor "
                      "hidden behind people found)\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("zone door        unseen for 2.1 s (0 of 20000 cells occupied, 12 unseen)\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("zone robot-cell  occupied for 2.1 s (447 of 20000 cells occupied)\n"),
            std::string::npos)
      << text;
}

}  // namespace
}  // namespace occmap
