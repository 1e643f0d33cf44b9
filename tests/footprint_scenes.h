#pragma once
// The zones and tracks that go with a scene map (tests/map_scenes.h), as occmapd publishes them
// beside each map (zones_t, tracks_t): what map_publisher --zones-and-tracks sends with map `seq`,
// so that a test can say what a subscriber must print for it. Each value follows from seq alone.

#include <cstdint>

#include <occmap/tracks_t.hpp>
#include <occmap/zones_t.hpp>

namespace occmap::testing {

inline constexpr const char* kSceneHostname = "test-host";

// Two zones: "aisle", free, occupied and unseen in turn (40 maps each), and "robot-cell", free
// for the whole run.
inline occmap::zones_t sceneZones(std::int64_t seq, std::int64_t utime) {
  occmap::zones_t zones{};
  zones.utime = utime;
  zones.seq = seq;
  zones.hostname = kSceneHostname;
  occmap::zone_t aisle{};
  aisle.name = "aisle";
  aisle.state = static_cast<std::int8_t>(seq / 40 % 3);
  aisle.state_s = static_cast<double>(seq % 40) / 30.0;
  aisle.cells = 400;
  aisle.occupied_cells =
      aisle.state == occmap::zone_t::OCCUPIED ? static_cast<int>(10 + seq % 5) : 0;
  aisle.unseen_cells = aisle.state == occmap::zone_t::UNSEEN ? 7 : 0;
  aisle.corner_x_m = {0.0, 0.4, 0.4, 0.0};
  aisle.corner_y_m = {0.0, 0.0, 1.0, 1.0};
  aisle.num_corners = 4;
  occmap::zone_t cell{};
  cell.name = "robot-cell";
  cell.state = occmap::zone_t::FREE;
  cell.state_s = 100.0 + static_cast<double>(seq) / 30.0;
  cell.cells = 2500;
  cell.corner_x_m = {1.0, 2.0, 1.5};
  cell.corner_y_m = {1.0, 1.0, 2.0};
  cell.num_corners = 3;
  zones.zones = {aisle, cell};
  zones.num_zones = 2;
  return zones;
}

// One to three footprints; a person walking along +x (id 3), and on even maps a second one walking
// along -y (id 8).
inline occmap::tracks_t sceneTracks(std::int64_t seq, std::int64_t utime) {
  occmap::tracks_t tracks{};
  tracks.utime = utime;
  tracks.seq = seq;
  tracks.hostname = kSceneHostname;
  for (std::int64_t k = 0; k <= seq % 3; ++k) {
    tracks.footprints.push_back({0.5 * static_cast<double>(k), 1.0, 0.2, 0.5, 1.75});
  }
  tracks.num_footprints = static_cast<std::int16_t>(tracks.footprints.size());
  const double t = static_cast<double>(seq);
  tracks.tracks.push_back({3, -1.0 + 0.04 * t, 0.5, 1.2, 0.0, 0.2, t / 30.0, 0.0});
  if (seq % 2 == 0) tracks.tracks.push_back({8, 2.0, 1.0 - 0.02 * t, 0.0, -0.6, 0.18, 1.0, 0.0});
  tracks.num_tracks = static_cast<std::int16_t>(tracks.tracks.size());
  return tracks;
}

}  // namespace occmap::testing
