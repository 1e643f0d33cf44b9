#include "web/footprints_json.h"

#include <cstdint>

#include <nlohmann/json.hpp>

#include "transport/status_text.h"

namespace occmap::web {
namespace {

// As formatStatusJson dumps: ASCII, invalid UTF-8 replaced, NaN and infinities as null.
std::string dumpJson(const nlohmann::ordered_json& j) {
  return j.dump(-1, ' ', true, nlohmann::ordered_json::error_handler_t::replace);
}

}  // namespace

std::string tracksJson(const occmap::tracks_t& t) {
  nlohmann::ordered_json j = {{"utime", t.utime}, {"seq", t.seq}, {"hostname", t.hostname}};
  nlohmann::ordered_json& found = j["footprints"] = nlohmann::ordered_json::array();
  for (const occmap::footprint_t& f : t.footprints) {
    found.push_back(nlohmann::ordered_json{{"x_m", f.x_m},
                                           {"y_m", f.y_m},
                                           {"area_m2", f.area_m2},
                                           {"score", f.score},
                                           {"height_m", f.height_m}});
  }
  nlohmann::ordered_json& followed = j["tracks"] = nlohmann::ordered_json::array();
  for (const occmap::track_t& track : t.tracks) {
    followed.push_back(nlohmann::ordered_json{
        {"id", track.id},
        {"x_m", track.x_m},
        {"y_m", track.y_m},
        {"vx_m_s", track.vx_m_s},
        {"vy_m_s", track.vy_m_s},
        {"area_m2", track.area_m2},
        {"age_s", track.age_s},
        {"unseen_s", track.unseen_s},
    });
  }
  return dumpJson(j);
}

std::string zonesJson(const occmap::zones_t& z) {
  nlohmann::ordered_json j = {{"utime", z.utime}, {"seq", z.seq}, {"hostname", z.hostname}};
  nlohmann::ordered_json& zones = j["zones"] = nlohmann::ordered_json::array();
  for (const occmap::zone_t& zone : z.zones) {
    zones.push_back(nlohmann::ordered_json{
        {"name", zone.name},
        {"state", std::int64_t{zone.state}},
        {"state_name", zoneStateText(zone.state)},
        {"state_s", zone.state_s},
        {"cells", zone.cells},
        {"occupied_cells", zone.occupied_cells},
        {"unseen_cells", zone.unseen_cells},
        {"corner_x_m", zone.corner_x_m},
        {"corner_y_m", zone.corner_y_m},
    });
  }
  return dumpJson(j);
}

}  // namespace occmap::web
