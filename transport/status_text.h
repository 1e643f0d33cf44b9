#pragma once
// occmapd's status (occmap.status_t) as text for people and as JSON for programs: what
// `occmap status` prints, and what the daemon can write to its log. A status may come from anyone
// on the network segment, so neither trusts its texts or numbers: the table shows control
// characters and bytes that are not UTF-8 as '?' (nothing reaches the terminal as an escape
// sequence), the JSON (nlohmann/json) is ASCII with every other character escaped and bytes that
// are not UTF-8 as U+FFFD, and no value overflows.

#include <string>
#include <string_view>

#include <occmap/control_status_t.hpp>
#include <occmap/lighting_status_t.hpp>
#include <occmap/merge_status_t.hpp>
#include <occmap/status_t.hpp>
#include <occmap/tracks_t.hpp>
#include <occmap/view_status_t.hpp>
#include <occmap/zones_t.hpp>

namespace occmap {

// What `occmap status` heard on the map's channels while it waited for the daemon's answer
// (transport/footprints_message.h): the answering daemon's newest zones_t and tracks_t, each
// nullptr when none came, and for how long it listened.
struct ZonesAndTracks {
  const occmap::zones_t* zones = nullptr;
  const occmap::tracks_t* tracks = nullptr;
  double listened_s = 0;
};

// A few lines on the daemon (state, uptime, maps published, publish errors, maps/s, fusion p50 and
// p99), then a table with one row per camera: name, state, frames in, dropped, fps, and the age of
// its last capture at the time of the status. With `control` (the control_status_t published with
// it), then formatControlStatusTable(*control); with `lighting`, formatLightingStatusTable (with
// `view`, if given); with `heard`, a blank line and formatZonesAndTracks(*heard). Ends with a
// newline.
std::string formatStatusTable(const occmap::status_t& status,
                              const occmap::control_status_t* control = nullptr,
                              const occmap::lighting_status_t* lighting = nullptr,
                              const occmap::view_status_t* view = nullptr,
                              const ZonesAndTracks* heard = nullptr);

// The zones and the tracks as lines for the status table: a line per zone, its state and for how
// long ("zone robot-cell  occupied for 3.2 s (41 of 2500 cells occupied)"), then one for the
// tracks ("2 tracked: #4 at (1.20, 0.35) m moving 0.8 m/s, #7 at ...; 3 footprints on map
// 1205"). For a message that did not come, a line that says so and what may be why ("no tracks_t
// heard in 0.7 s (is footprints: enabled: false?)"). Ends with a newline.
std::string formatZonesAndTracks(const ZonesAndTracks& heard);

// A zone_t's state in words: "free", "occupied", "unseen" (core/zones.h); "state N" for a value
// the type does not define. The one wording of every command that shows zones.
std::string zoneStateText(int state);

// Each camera's light (docs/lighting.md), a line per camera: the gain against the background's
// light and the share of pixels that agreed, or why it is degraded (with `view`, the
// view_status_t published with it: whether the camera was moved, and how far it turned);
// nothing for cameras whose model is off. Ends with a newline, or is empty.
std::string formatLightingStatusTable(const occmap::lighting_status_t& lighting,
                                      const occmap::view_status_t* view = nullptr);

// What became of control requests, as lines for the status table: one with the six counters and,
// when control is enabled, one per camera with its threshold and background. Ends with a newline.
std::string formatControlStatusTable(const occmap::control_status_t& control);

// One JSON object on one line (no newline, no blanks), every field of status_t by its LCM name in
// its order, states also by name ("state_name"), cameras as an array of objects; numbers that are
// not finite as null. With `control`, its fields follow
// ("control_enabled", the six counters as "control_disabled" ... "control_accepted", and the
// arrays "camera_name", "camera_threshold", "camera_background_utime"). With `lighting`, its
// arrays as "lighting_adapt", "lighting_gain", "lighting_agreement", "lighting_explained" and
// "lighting_unexplained_frames", in the order of its camera names ("lighting_camera_name"). With
// `view`, its arrays as "view_camera_name", "view" (the numbers), "view_name" ("as calibrated",
// "unexplained", "moved"), "view_shift_x_px", "view_shift_y_px", "view_turn_deg",
// "view_residual_px", "view_checked_utime", "view_reposes", "view_reposed_turn_deg" and
// "view_reposed_utime". With `heard`, "zones": an array of zone_t objects (every field by its LCM
// name but num_corners, the state also by name, "state_name"), and "tracks": the tracks_t as an
// object ("utime", "seq", "hostname", "footprints" and "tracks" as arrays of footprint_t and
// track_t objects); each null when none was heard.
std::string formatStatusJson(const occmap::status_t& status,
                             const occmap::control_status_t* control = nullptr,
                             const occmap::lighting_status_t* lighting = nullptr,
                             const occmap::view_status_t* view = nullptr,
                             const ZonesAndTracks* heard = nullptr);

// A merge node's status (merge_status_t, docs/merge.md) as `occmap status` shows it, the way
// formatStatusTable shows a camera PC's: a few lines on the node (state, uptime, merged maps
// published and on which channel, publish errors, maps/s, how many inputs are fresh within
// max_age_ms, the latency from the newest input's arrival to the merged map's publish as p50, p99
// and last, the time to take one input map in as p50 and p99), then a table with one row per
// input: name, channel, state, maps heard, maps/s, how far its newest capture is behind the newest
// input's, lost maps and its clock offset ("?" until known). Below it, for each input whose clock
// is more than clock_warning_ms off, a warning line; for each that refused messages, how many and
// its last error. With `heard`, a blank line and the zones and tracks as formatZonesAndTracks
// (the tracks on the merged map, made of what the camera PCs found: docs/merge.md), or that none
// were heard. Ends with a newline.
std::string formatMergeStatusTable(const occmap::merge_status_t& status,
                                   const ZonesAndTracks* heard = nullptr);

// One JSON object on one line, as formatStatusJson: every field of merge_status_t by its LCM name
// in its order, the state also by name ("state_name"), "inputs" an array of objects with every
// field of merge_input_status_t (and "state_name": "never heard", "fresh", "down"); numbers that
// are not finite (an input's age_ms and clock_offset_ms before they are known) as null. With
// `heard`, "zones" and "tracks" as formatStatusJson has them. A reader tells it from a camera PC's
// by "inputs" where that has "cameras".
std::string formatMergeStatusJson(const occmap::merge_status_t& status,
                                  const ZonesAndTracks* heard = nullptr);

// "never heard", "fresh", "down" (merge_input_status_t.STATE_*); "state N" otherwise.
std::string mergeInputStateName(int state);

// "as calibrated", "unexplained", "moved" (view_status_t); "view N" otherwise.
std::string viewName(int view);
// How an image moved, in words: "10.0 px right and 3.3 px up" (+y is down).
std::string imageShiftText(double x_px, double y_px);

// A text from the network (a host or camera name, an error) as it may be printed on a terminal:
// control characters and bytes that are not UTF-8 become '?', so an escape sequence shows as text.
std::string terminalText(std::string_view text);

// "starting", "running", "reloading", "stopping"; "state N" for a value this build does not know.
std::string daemonStateName(int state);
// "starting", "streaming", "down"; "state N" otherwise.
std::string cameraStateName(int state);

// A tracks_t as formatStatusJson's "tracks" holds it: {"utime", "seq", "hostname", "footprints":
// [{x_m, y_m, area_m2, score, height_m}...], "tracks": [{id, x_m, y_m, vx_m_s, vy_m_s, area_m2,
// age_s, unseen_s}...]} on one line (GET /api/tracks of occmap web).
std::string formatTracksJson(const occmap::tracks_t& tracks);
// A zones_t: {"utime", "seq", "hostname", "zones": [...]}, the zones as formatStatusJson's "zones"
// holds them (GET /api/zones of occmap web).
std::string formatZonesJson(const occmap::zones_t& zones);

}  // namespace occmap
