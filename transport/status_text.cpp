#include "transport/status_text.h"

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/format_text.h"
#include "core/zones.h"

namespace occmap {
namespace {

// The index of camera `name` in `view`'s arrays, or kNoView (no view_status_t, a daemon from
// before it, or a hand-made one whose arrays are short).
constexpr std::size_t kNoView = static_cast<std::size_t>(-1);
std::size_t viewIndex(const occmap::view_status_t* view, const std::string& name) {
  if (view == nullptr) return kNoView;
  const std::size_t cameras =
      std::min({view->camera_name.size(), view->view.size(), view->shift_x_px.size(),
                view->shift_y_px.size(), view->turn_deg.size(), view->residual_px.size(),
                view->checked_utime.size(), view->reposes.size(), view->reposed_turn_deg.size(),
                view->reposed_utime.size()});
  for (std::size_t v = 0; v < cameras; ++v) {
    if (view->camera_name[v] == name) return v;
  }
  return kNoView;
}

// The length of the UTF-8 sequence of one code point at text[at], and the code point; 0 when the
// bytes there are not one (a stray continuation byte, an overlong form, a surrogate, past
// U+10FFFF).
std::size_t utf8Sequence(std::string_view text, std::size_t at, char32_t& code_point) {
  const auto byte = [&](std::size_t k) -> unsigned {
    return at + k < text.size() ? static_cast<unsigned char>(text[at + k]) : 0u;
  };
  const unsigned lead = byte(0);
  if (lead < 0x80) {
    code_point = lead;
    return 1;
  }
  std::size_t length = 0;
  char32_t value = 0;
  char32_t smallest = 0;  // the least code point of this length: below it the form is overlong
  if ((lead & 0xE0u) == 0xC0u) {
    length = 2;
    value = lead & 0x1Fu;
    smallest = 0x80;
  } else if ((lead & 0xF0u) == 0xE0u) {
    length = 3;
    value = lead & 0x0Fu;
    smallest = 0x800;
  } else if ((lead & 0xF8u) == 0xF0u) {
    length = 4;
    value = lead & 0x07u;
    smallest = 0x10000;
  } else {
    return 0;  // a continuation byte, or no lead byte at all
  }
  for (std::size_t k = 1; k < length; ++k) {
    if ((byte(k) & 0xC0u) != 0x80u) return 0;
    value = value << 6 | (byte(k) & 0x3Fu);
  }
  if (value < smallest || value > 0x10FFFF || (value >= 0xD800 && value <= 0xDFFF)) return 0;
  code_point = value;
  return length;
}

// C0 controls, DEL and C1 controls: what a terminal may act on (escape sequences, carriage
// returns).
bool isControl(char32_t code_point) {
  return code_point < 0x20 || (code_point >= 0x7F && code_point < 0xA0);
}

std::string uptime(double seconds) {
  // Beyond 10^12 s (31 700 years) the daemon's figure is not an uptime, and no int64 holds 1e300.
  if (!std::isfinite(seconds) || seconds < 0 || seconds >= 1e12) return "?";
  const auto total = static_cast<std::int64_t>(seconds);
  const std::int64_t days = total / 86400;
  const std::string clock = formatText("%" PRId64 ":%02" PRId64 ":%02" PRId64, total % 86400 / 3600,
                                       total % 3600 / 60, total % 60);
  return days > 0 ? formatText("%" PRId64 " d ", days) + clock : clock;
}

// How long before the status its camera's newest frame was captured (both times are the daemon's
// clock, so no clock skew between machines enters).
std::string age(std::int64_t status_utime, std::int64_t capture_utime) {
  if (capture_utime == 0) return "never";
  // In double: the difference of two int64 values from the network may not fit an int64.
  const double ms =
      (static_cast<double>(status_utime) - static_cast<double>(capture_utime)) / 1000.0;
  if (std::fabs(ms) < 1000.0) return formatText("%.0f ms ago", ms);
  return formatText("%.1f s ago", ms / 1000.0);
}

// How long something has lasted: "3.2 s" under a minute, else as an uptime.
std::string duration(double seconds) {
  if (std::isfinite(seconds) && seconds >= 0 && seconds < 59.95)
    return formatText("%.1f s", seconds);
  return uptime(seconds);
}

std::string formatZones(const occmap::zones_t& z) {
  if (z.zones.empty()) return "zones: none (a zones_t without zones)\n";
  std::vector<std::string> names;
  for (const occmap::zone_t& zone : z.zones) names.push_back(terminalText(zone.name));
  std::size_t name_width = 0;
  for (const std::string& name : names) name_width = std::max(name_width, name.size());
  const int w = static_cast<int>(std::min<std::size_t>(name_width, 64));
  std::string text;
  for (std::size_t k = 0; k < z.zones.size(); ++k) {
    const occmap::zone_t& zone = z.zones[k];
    text += formatText("zone %-*s  %s for %s (%d of %d cells occupied", w, names[k].c_str(),
                       zoneStateText(zone.state).c_str(), duration(zone.state_s).c_str(),
                       zone.occupied_cells, zone.cells);
    if (zone.unseen_cells != 0) text += formatText(", %d unseen", zone.unseen_cells);
    // Unseen with occupied cells: occmapd found every one of them to be floor hidden behind
    // people found (core/hidden_floor.h).
    if (zone.state == occmap::zone_t::UNSEEN && zone.occupied_cells > 0) {
      text += ", all floor hidden behind people found";
    }
    text += ")\n";
  }
  return text;
}

std::string formatTracks(const occmap::tracks_t& t) {
  const std::size_t tracked = t.tracks.size();
  // Tracks are people and objects alike (a chair pushed, a robot): "tracked", not "people".
  std::string text = tracked == 0   ? std::string("nothing tracked")
                     : tracked == 1 ? std::string("1 tracked: ")
                                    : formatText("%zu tracked: ", tracked);
  for (std::size_t k = 0; k < tracked; ++k) {
    const occmap::track_t& track = t.tracks[k];
    text += formatText("%s#%d at (%.2f, %.2f) m moving %.1f m/s", k == 0 ? "" : ", ", track.id,
                       track.x_m, track.y_m, std::hypot(track.vx_m_s, track.vy_m_s));
  }
  const std::size_t found = t.footprints.size();
  const std::string map =
      t.seq < 0 ? std::string("a map never sent") : formatText("map %" PRId64, t.seq);
  return text + formatText("; %zu footprint%s on %s\n", found, found == 1 ? "" : "s", map.c_str());
}

// How far an input's newest capture is behind the newest input's: "12 ms", "3.4 s"; "-" before
// its first map (NaN) or for a figure that is no time.
std::string behindText(double ms) {
  if (!std::isfinite(ms) || std::fabs(ms) >= 1e12) return "-";
  if (std::fabs(ms) < 1000.0) return formatText("%.0f ms", ms);
  return formatText("%.1f s", ms / 1000.0);
}

// An input's clock offset: "+0.4 ms"; "?" until it is known (NaN).
std::string clockOffsetText(double ms) {
  if (!std::isfinite(ms) || std::fabs(ms) >= 1e12) return "?";
  return formatText("%+.1f ms", ms);
}

// The zones of a zones_t, as an array of objects: every field by its LCM name, the state also by
// name.
nlohmann::ordered_json zonesArrayJson(const occmap::zones_t& z) {
  nlohmann::ordered_json zones = nlohmann::ordered_json::array();
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
  return zones;
}

// A tracks_t as an object: utime, seq, hostname, its footprints and its tracks.
nlohmann::ordered_json tracksObjectJson(const occmap::tracks_t& t) {
  nlohmann::ordered_json tracks = {{"utime", t.utime}, {"seq", t.seq}, {"hostname", t.hostname}};
  nlohmann::ordered_json& found = tracks["footprints"] = nlohmann::ordered_json::array();
  for (const occmap::footprint_t& f : t.footprints) {
    found.push_back(nlohmann::ordered_json{{"x_m", f.x_m},
                                           {"y_m", f.y_m},
                                           {"area_m2", f.area_m2},
                                           {"score", f.score},
                                           {"height_m", f.height_m}});
  }
  nlohmann::ordered_json& followed = tracks["tracks"] = nlohmann::ordered_json::array();
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
  return tracks;
}

// "zones" (an array of zone_t objects, or null when none was heard) and "tracks" (the tracks_t
// as an object, or null) for formatStatusJson and formatMergeStatusJson.
void addZonesAndTracksJson(nlohmann::ordered_json& j, const ZonesAndTracks& heard) {
  j["zones"] = heard.zones != nullptr ? zonesArrayJson(*heard.zones) : nullptr;
  j["tracks"] = heard.tracks != nullptr ? tracksObjectJson(*heard.tracks) : nullptr;
}

// As every JSON here is printed: ASCII, bytes that are not UTF-8 replaced, NaN and infinities
// null (nlohmann writes them so).
std::string dumpStatusJson(const nlohmann::ordered_json& j) {
  return j.dump(-1, ' ', true, nlohmann::ordered_json::error_handler_t::replace);
}

}  // namespace

std::string zoneStateText(int state) {
  if (state < 0 || state > 2) return formatText("state %d", state);
  return std::string(zoneStateName(static_cast<ZoneState>(state)));
}

std::string formatZonesAndTracks(const ZonesAndTracks& heard) {
  std::string text =
      heard.zones != nullptr
          ? formatZones(*heard.zones)
          : formatText("no zones_t heard in %.1f s (are there zones: in the config?)\n",
                       heard.listened_s);
  text += heard.tracks != nullptr
              ? formatTracks(*heard.tracks)
              : formatText("no tracks_t heard in %.1f s (is footprints: enabled: false?)\n",
                           heard.listened_s);
  return text;
}

std::string terminalText(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t at = 0; at < text.size();) {
    char32_t code_point = 0;
    const std::size_t length = utf8Sequence(text, at, code_point);
    if (length == 0 || isControl(code_point)) {
      out += '?';
      at += length == 0 ? 1 : length;
    } else {
      out.append(text.substr(at, length));
      at += length;
    }
  }
  return out;
}

std::string daemonStateName(int state) {
  switch (state) {
    case occmap::status_t::STATE_STARTING:
      return "starting";
    case occmap::status_t::STATE_RUNNING:
      return "running";
    case occmap::status_t::STATE_RELOADING:
      return "reloading";
    case occmap::status_t::STATE_STOPPING:
      return "stopping";
    default:
      return formatText("state %d", state);
  }
}

std::string cameraStateName(int state) {
  switch (state) {
    case 0:
      return "starting";
    case 1:
      return "streaming";
    case 2:
      return "down";
    default:
      return formatText("state %d", state);
  }
}

std::string formatStatusTable(const occmap::status_t& s, const occmap::control_status_t* control,
                              const occmap::lighting_status_t* lighting,
                              const occmap::view_status_t* view, const ZonesAndTracks* heard) {
  std::string text =
      "occmapd on " + (s.hostname.empty() ? std::string("?") : terminalText(s.hostname));
  if (!s.config_file.empty()) text += " (config " + terminalText(s.config_file) + ")";
  text += "\n";
  text += formatText("  state %s, up %s\n", daemonStateName(s.state).c_str(),
                     uptime(s.uptime_s).c_str());
  text += formatText("  maps published %" PRId64 " (%.1f maps/s), publish errors %" PRId64 "\n",
                     s.maps_published, s.maps_per_s, s.publish_errors);
  text += formatText("  fusion per frame set: p50 %.2f ms, p99 %.2f ms\n", s.fusion_p50_ms,
                     s.fusion_p99_ms);
  std::vector<std::string> names;
  for (const auto& camera : s.cameras) names.push_back(terminalText(camera.name));
  // Camera names are at most 64 characters (config.h); a longer one runs past its column.
  std::size_t name_width = 6;
  for (const std::string& name : names) name_width = std::max(name_width, name.size());
  const int w = static_cast<int>(std::min<std::size_t>(name_width, 64));
  text += formatText("\n%-*s  %-9s  %10s  %8s  %6s  %s\n", w, "camera", "state", "frames in",
                     "dropped", "fps", "last capture");
  for (std::size_t k = 0; k < s.cameras.size(); ++k) {
    const auto& c = s.cameras[k];
    text += formatText("%-*s  %-9s  %10" PRId64 "  %8" PRId64 "  %6.1f  %s\n", w, names[k].c_str(),
                       cameraStateName(c.state).c_str(), c.frames_in, c.frames_dropped, c.fps,
                       age(s.utime, c.last_capture_utime).c_str());
  }
  if (s.cameras.empty()) text += "(no cameras)\n";
  for (std::size_t k = 0; k < s.cameras.size(); ++k) {
    const auto& c = s.cameras[k];
    if (c.frames_incomplete || c.missing_packets || c.resent_packets || c.underruns ||
        c.reconnects) {
      text += formatText("%s: %" PRId64 " incomplete frames, %" PRId64 " packets missing, %" PRId64
                         " resent, %" PRId64 " underruns, %d reconnects\n",
                         names[k].c_str(), c.frames_incomplete, c.missing_packets, c.resent_packets,
                         c.underruns, c.reconnects);
    }
    if (!c.last_error.empty())
      text += names[k] + ": last error: " + terminalText(c.last_error) + "\n";
  }
  if (control != nullptr) text += formatControlStatusTable(*control);
  if (lighting != nullptr) text += formatLightingStatusTable(*lighting, view);
  if (heard != nullptr) text += "\n" + formatZonesAndTracks(*heard);
  return text;
}

std::string imageShiftText(double x_px, double y_px) {
  return formatText("%.1f px %s and %.1f px %s", std::abs(x_px), x_px < 0 ? "left" : "right",
                    std::abs(y_px), y_px < 0 ? "up" : "down");
}

std::string viewName(int view) {
  switch (view) {
    case occmap::view_status_t::AS_CALIBRATED:
      return "as calibrated";
    case occmap::view_status_t::UNEXPLAINED:
      return "unexplained";
    case occmap::view_status_t::MOVED:
      return "moved";
    default:
      return formatText("view %d", view);
  }
}

std::string formatLightingStatusTable(const occmap::lighting_status_t& l,
                                      const occmap::view_status_t* view) {
  // The arrays are as long as num_cameras in any message that decodes; a hand-made one may not be.
  const std::size_t cameras =
      std::min({l.camera_name.size(), l.adapt.size(), l.gain.size(), l.agreement.size(),
                l.explained.size(), l.unexplained_frames.size()});
  std::string text;
  for (std::size_t k = 0; k < cameras; ++k) {
    if (l.adapt[k] == 0) continue;
    const std::string name = terminalText(l.camera_name[k]);
    if (l.explained[k] != 0) {
      text += formatText("%s: light %.2f x the background's (%.0f %% of pixels agree)",
                         name.c_str(), l.gain[k], 100 * l.agreement[k]);
    } else if (const std::size_t v = viewIndex(view, l.camera_name[k]);
               v != kNoView && view->view[v] == occmap::view_status_t::MOVED) {
      text += formatText(
          "%s: DEGRADED, MOVED: it turned %.2f degrees on its mount (the image shifted %s, "
          "%.2f px off a turn alone); its calibration no longer holds and its cells are unseen "
          "until occmapd re-poses it, once its view is still (if it was turned, not moved "
          "along); or put it back",
          name.c_str(), view->turn_deg[v],
          imageShiftText(view->shift_x_px[v], view->shift_y_px[v]).c_str(), view->residual_px[v]);
    } else if (v != kNoView && view->view[v] == occmap::view_status_t::UNEXPLAINED) {
      text += formatText(
          "%s: DEGRADED, no change of light explains its view (%.0f %% of pixels agree) and it "
          "is not its background moved: covered, lights out, crowded, or changed beyond "
          "recognition; its cells are unseen",
          name.c_str(), 100 * l.agreement[k]);
    } else {
      text += formatText(
          "%s: DEGRADED, no change of light explains its view (%.0f %% of pixels "
          "agree): bumped, covered, lights out or crowded; its cells are unseen",
          name.c_str(), 100 * l.agreement[k]);
    }
    if (l.unexplained_frames[k] > 0) {
      text += formatText("; %" PRId64 " frames left out so far", l.unexplained_frames[k]);
    }
    if (const std::size_t v = viewIndex(view, l.camera_name[k]);
        v != kNoView && view->reposes[v] > 0) {
      text += formatText(
          "; re-posed %d time%s after a knock (last turned %.2f degrees): its "
          "calibration file still has the old pose",
          view->reposes[v], view->reposes[v] == 1 ? "" : "s", view->reposed_turn_deg[v]);
    }
    text += "\n";
  }
  return text;
}

std::string formatControlStatusTable(const occmap::control_status_t& c) {
  std::string text = formatText("control requests %s: accepted %" PRId64 ", refused %" PRId64
                                "; ignored: %" PRId64 " while off, %" PRId64 " malformed, %" PRId64
                                " bad mac, %" PRId64 " stale or replayed\n",
                                c.control_enabled ? "on" : "off", c.accepted, c.refused, c.disabled,
                                c.malformed, c.bad_mac, c.stale);
  if (!c.control_enabled) return text;
  // What a control request changed, per camera (the arrays are as long as num_cameras in any
  // message that decodes; a hand-made one may not be).
  const std::size_t cameras =
      std::min({c.camera_name.size(), c.camera_threshold.size(), c.camera_background_utime.size()});
  for (std::size_t k = 0; k < cameras; ++k) {
    const std::int64_t made = c.camera_background_utime[k];
    const std::string background =
        made == 0 ? std::string("from the config") : "recaptured " + age(c.utime, made);
    text += formatText("%s: threshold %d, background %s\n", terminalText(c.camera_name[k]).c_str(),
                       c.camera_threshold[k], background.c_str());
  }
  return text;
}

std::string formatStatusJson(const occmap::status_t& s, const occmap::control_status_t* control,
                             const occmap::lighting_status_t* lighting,
                             const occmap::view_status_t* view, const ZonesAndTracks* heard) {
  // ordered_json: the keys in the order of status_t's fields, as a reader of the LCM type expects.
  nlohmann::ordered_json j = {
      {"utime", s.utime},
      {"request_id", s.request_id},
      {"hostname", s.hostname},
      {"config_file", s.config_file},
      {"state", std::int64_t{s.state}},
      {"state_name", daemonStateName(s.state)},
      {"uptime_s", s.uptime_s},
      {"maps_published", s.maps_published},
      {"publish_errors", s.publish_errors},
      {"maps_per_s", s.maps_per_s},
      {"fusion_p50_ms", s.fusion_p50_ms},
      {"fusion_p99_ms", s.fusion_p99_ms},
  };
  nlohmann::ordered_json& cameras = j["cameras"] = nlohmann::ordered_json::array();
  for (const auto& c : s.cameras) {
    cameras.push_back(nlohmann::ordered_json{
        {"name", c.name},
        {"source", c.source},
        {"state", std::int64_t{c.state}},
        {"state_name", cameraStateName(c.state)},
        {"frames_in", c.frames_in},
        {"frames_dropped", c.frames_dropped},
        {"fps", c.fps},
        {"last_capture_utime", c.last_capture_utime},
        {"frames_incomplete", c.frames_incomplete},
        {"missing_packets", c.missing_packets},
        {"resent_packets", c.resent_packets},
        {"underruns", c.underruns},
        {"reconnects", std::int64_t{c.reconnects}},
        {"last_error", c.last_error},
    });
  }
  if (control != nullptr) {
    // The control_status_t's fields, named as they would be if they were status_t's (control_*),
    // and the per-camera arrays in the order of its camera_name.
    const occmap::control_status_t& c = *control;
    j["control_enabled"] = c.control_enabled != 0;
    j["control_disabled"] = c.disabled;
    j["control_malformed"] = c.malformed;
    j["control_bad_mac"] = c.bad_mac;
    j["control_stale"] = c.stale;
    j["control_refused"] = c.refused;
    j["control_accepted"] = c.accepted;
    j["camera_name"] = c.camera_name;
    j["camera_threshold"] = c.camera_threshold;
    j["camera_background_utime"] = c.camera_background_utime;
  }
  if (lighting != nullptr) {
    const occmap::lighting_status_t& l = *lighting;
    j["lighting_camera_name"] = l.camera_name;
    nlohmann::ordered_json& adapt = j["lighting_adapt"] = nlohmann::ordered_json::array();
    for (const std::int8_t on : l.adapt) adapt.push_back(on != 0);
    j["lighting_gain"] = l.gain;
    j["lighting_agreement"] = l.agreement;
    nlohmann::ordered_json& explained = j["lighting_explained"] = nlohmann::ordered_json::array();
    for (const std::int8_t yes : l.explained) explained.push_back(yes != 0);
    j["lighting_unexplained_frames"] = l.unexplained_frames;
  }
  if (view != nullptr) {
    const occmap::view_status_t& v = *view;
    j["view_camera_name"] = v.camera_name;
    j["view"] = v.view;
    nlohmann::ordered_json& names = j["view_name"] = nlohmann::ordered_json::array();
    for (const std::int8_t state : v.view) names.push_back(viewName(state));
    j["view_shift_x_px"] = v.shift_x_px;
    j["view_shift_y_px"] = v.shift_y_px;
    j["view_turn_deg"] = v.turn_deg;
    j["view_residual_px"] = v.residual_px;
    j["view_checked_utime"] = v.checked_utime;
    j["view_reposes"] = v.reposes;
    j["view_reposed_turn_deg"] = v.reposed_turn_deg;
    j["view_reposed_utime"] = v.reposed_utime;
  }
  if (heard != nullptr) addZonesAndTracksJson(j, *heard);
  // The texts are anyone's on the network: bytes that are not UTF-8 become U+FFFD (rather than an
  // exception), and ensure_ascii writes every character outside printable ASCII as \uXXXX, so that
  // no control character (C0, DEL, C1) reaches a terminal raw when the JSON is printed on one.
  // Non-finite numbers come out as null.
  return dumpStatusJson(j);
}

std::string mergeInputStateName(int state) {
  switch (state) {
    case occmap::merge_input_status_t::STATE_NEVER_HEARD:
      return "never heard";
    case occmap::merge_input_status_t::STATE_FRESH:
      return "fresh";
    case occmap::merge_input_status_t::STATE_DOWN:
      return "down";
    default:
      return formatText("state %d", state);
  }
}

std::string formatMergeStatusTable(const occmap::merge_status_t& s, const ZonesAndTracks* heard) {
  std::string text =
      "occmapd merge node on " + (s.hostname.empty() ? std::string("?") : terminalText(s.hostname));
  if (!s.config_file.empty()) text += " (config " + terminalText(s.config_file) + ")";
  text += "\n";
  text += formatText("  state %s, up %s\n", daemonStateName(s.state).c_str(),
                     uptime(s.uptime_s).c_str());
  text += formatText(
      "  merged maps published %" PRId64 " (%.1f maps/s) on %s, publish errors %" PRId64 "\n",
      s.maps_published, s.maps_per_s, terminalText(s.map_channel).c_str(), s.publish_errors);
  const auto fresh = std::count_if(s.inputs.begin(), s.inputs.end(), [](const auto& input) {
    return input.state == occmap::merge_input_status_t::STATE_FRESH;
  });
  text += formatText("  inputs fresh: %td of %zu (within %.0f ms of the newest input's capture)\n",
                     fresh, s.inputs.size(), s.max_age_ms);
  text += formatText(
      "  latency from the newest input's arrival to publish: p50 %.2f ms, p99 %.2f ms, last "
      "%.2f ms\n",
      s.latency_p50_ms, s.latency_p99_ms, s.latency_last_ms);
  text += formatText("  merge per input map: p50 %.2f ms, p99 %.2f ms\n", s.merge_p50_ms,
                     s.merge_p99_ms);

  std::vector<std::string> names, channels;
  for (const auto& input : s.inputs) {
    names.push_back(terminalText(input.name));
    channels.push_back(terminalText(input.channel));
  }
  // Names and channels are at most 64 characters wide in the table; a longer one runs past.
  std::size_t name_width = 5, channel_width = 7;
  for (const std::string& name : names) name_width = std::max(name_width, name.size());
  for (const std::string& channel : channels)
    channel_width = std::max(channel_width, channel.size());
  const int w = static_cast<int>(std::min<std::size_t>(name_width, 64));
  const int cw = static_cast<int>(std::min<std::size_t>(channel_width, 64));
  text += formatText("\n%-*s  %-*s  %-11s  %8s  %6s  %8s  %6s  %9s\n", w, "input", cw, "channel",
                     "state", "maps", "maps/s", "behind", "lost", "clock");
  for (std::size_t k = 0; k < s.inputs.size(); ++k) {
    const auto& input = s.inputs[k];
    text += formatText("%-*s  %-*s  %-11s  %8" PRId64 "  %6.1f  %8s  %6" PRId64 "  %9s\n", w,
                       names[k].c_str(), cw, channels[k].c_str(),
                       mergeInputStateName(input.state).c_str(), input.maps, input.maps_per_s,
                       behindText(input.age_ms).c_str(), input.lost_maps,
                       clockOffsetText(input.clock_offset_ms).c_str());
  }
  if (s.inputs.empty()) text += "(no inputs)\n";
  for (std::size_t k = 0; k < s.inputs.size(); ++k) {
    const auto& input = s.inputs[k];
    if (std::isfinite(input.clock_offset_ms) && s.clock_warning_ms > 0 &&
        std::fabs(input.clock_offset_ms) > s.clock_warning_ms) {
      text += formatText(
          "%s: CLOCK %.1f ms off the others' (more than %.0f ms): its maps are judged that much "
          "too old or too new, and its cells shown at another moment than theirs (docs/merge.md: "
          "chrony or PTP)\n",
          names[k].c_str(), input.clock_offset_ms, s.clock_warning_ms);
    }
    if (input.tiles_lost != 0) {
      text +=
          formatText("%s: %" PRId64 " tile%s of its maps lost on the way (their cells unseen)\n",
                     names[k].c_str(), input.tiles_lost, input.tiles_lost == 1 ? "" : "s");
    }
    if (input.refused != 0 || !input.last_error.empty()) {
      text += formatText("%s: %" PRId64 " message%s refused", names[k].c_str(), input.refused,
                         input.refused == 1 ? "" : "s");
      if (!input.last_error.empty()) text += ", last error: " + terminalText(input.last_error);
      text += "\n";
    }
  }
  if (heard != nullptr) {
    // As a camera PC's, but for why tracks may not come: a merge node tracks the people its
    // inputs found (docs/merge.md), and sends tracks_t when they send theirs.
    text += "\n";
    text += heard->zones != nullptr
                ? formatZones(*heard->zones)
                : formatText("no zones_t heard in %.1f s (are there zones: in the config?)\n",
                             heard->listened_s);
    text += heard->tracks != nullptr
                ? formatTracks(*heard->tracks)
                : formatText(
                      "no tracks_t heard in %.1f s (do the camera PCs send theirs? "
                      "footprints: enabled: false there?)\n",
                      heard->listened_s);
  }
  return text;
}

std::string formatMergeStatusJson(const occmap::merge_status_t& s, const ZonesAndTracks* heard) {
  nlohmann::ordered_json j = {
      {"utime", s.utime},
      {"request_id", s.request_id},
      {"hostname", s.hostname},
      {"config_file", s.config_file},
      {"map_channel", s.map_channel},
      {"state", std::int64_t{s.state}},
      {"state_name", daemonStateName(s.state)},
      {"uptime_s", s.uptime_s},
      {"maps_published", s.maps_published},
      {"publish_errors", s.publish_errors},
      {"maps_per_s", s.maps_per_s},
      {"max_age_ms", s.max_age_ms},
      {"latency_p50_ms", s.latency_p50_ms},
      {"latency_p99_ms", s.latency_p99_ms},
      {"latency_last_ms", s.latency_last_ms},
      {"merge_p50_ms", s.merge_p50_ms},
      {"merge_p99_ms", s.merge_p99_ms},
      {"clock_warning_ms", s.clock_warning_ms},
  };
  nlohmann::ordered_json& inputs = j["inputs"] = nlohmann::ordered_json::array();
  for (const auto& input : s.inputs) {
    inputs.push_back(nlohmann::ordered_json{
        {"name", input.name},
        {"channel", input.channel},
        {"state", std::int64_t{input.state}},
        {"state_name", mergeInputStateName(input.state)},
        {"maps", input.maps},
        {"maps_per_s", input.maps_per_s},
        {"age_ms", input.age_ms},
        {"lost_maps", input.lost_maps},
        {"tiles_lost", input.tiles_lost},
        {"refused", input.refused},
        {"clock_offset_ms", input.clock_offset_ms},
        {"last_error", input.last_error},
    });
  }
  if (heard != nullptr) addZonesAndTracksJson(j, *heard);
  // As formatStatusJson: ASCII only, bytes that are not UTF-8 as U+FFFD, NaN as null.
  return dumpStatusJson(j);
}

std::string formatTracksJson(const occmap::tracks_t& tracks) {
  return dumpStatusJson(tracksObjectJson(tracks));
}

std::string formatZonesJson(const occmap::zones_t& zones) {
  nlohmann::ordered_json j = {
      {"utime", zones.utime}, {"seq", zones.seq}, {"hostname", zones.hostname}};
  j["zones"] = zonesArrayJson(zones);
  return dumpStatusJson(j);
}

}  // namespace occmap
