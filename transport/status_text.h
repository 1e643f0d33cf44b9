#pragma once
// occmapd's status (occmap.status_t) as text for people and as JSON for programs: what
// `occmap status` prints, and what the daemon can write to its log. A status may come from anyone
// on the network segment, so neither trusts its texts or numbers: the table shows control
// characters and bytes that are not UTF-8 as '?' (nothing reaches the terminal as an escape
// sequence), the JSON is valid UTF-8 with control characters escaped, and no value overflows.

#include <string>
#include <string_view>

#include <occmap/status_t.hpp>

namespace occmap {

// A few lines on the daemon (state, uptime, maps published, publish errors, maps/s, fusion p50 and
// p99), then a table with one row per camera: name, state, frames in, dropped, fps, and the age of
// its last capture at the time of the status. Ends with a newline.
std::string formatStatusTable(const occmap::status_t& status);

// One JSON object on one line (no newline), every field of status_t by its LCM name, states also
// by name ("state_name"), cameras as an array of objects.
std::string formatStatusJson(const occmap::status_t& status);

// A text from the network (a host or camera name, an error) as it may be printed on a terminal:
// control characters and bytes that are not UTF-8 become '?', so an escape sequence shows as text.
std::string terminalText(std::string_view text);

// "starting", "running", "reloading", "stopping"; "state N" for a value this build does not know.
std::string daemonStateName(int state);
// "starting", "streaming", "down"; "state N" otherwise.
std::string cameraStateName(int state);

}  // namespace occmap
