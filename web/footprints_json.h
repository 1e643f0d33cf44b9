#pragma once
// The newest tracks_t and zones_t as JSON, for GET /api/tracks, GET /api/zones and the page. Each
// object has the fields `occmap status --json` gives its "tracks" and "zones" (transport/
// status_text.h, formatStatusJson: every field by its LCM name, a zone's state also by name),
// with the message's utime, seq and hostname. The texts come from anyone on the network: ASCII
// only, every other character escaped, bytes that are not UTF-8 as U+FFFD, numbers that are not
// finite as null.

#include <string>

#include <occmap/tracks_t.hpp>
#include <occmap/zones_t.hpp>

namespace occmap::web {

// {"utime":…,"seq":…,"hostname":…,"footprints":[{x_m, y_m, area_m2, score, height_m}…],
//  "tracks":[{id, x_m, y_m, vx_m_s, vy_m_s, area_m2, age_s, unseen_s}…]}
std::string tracksJson(const occmap::tracks_t& tracks);

// {"utime":…,"seq":…,"hostname":…,"zones":[{name, state, state_name, state_s, cells,
//  occupied_cells, unseen_cells, corner_x_m, corner_y_m}…]}
std::string zonesJson(const occmap::zones_t& zones);

}  // namespace occmap::web
