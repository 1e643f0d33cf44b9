#include "transport/status_text.h"

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdarg>
#include <cstdio>

namespace occmap {
namespace {

__attribute__((format(printf, 1, 2))) std::string format(const char* pattern, ...) {
  char text[512];
  va_list arguments;
  va_start(arguments, pattern);
  std::vsnprintf(text, sizeof text, pattern, arguments);
  va_end(arguments);
  return text;
}

std::string uptime(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  const auto total = static_cast<std::int64_t>(seconds);
  const std::int64_t days = total / 86400;
  const std::string clock = format("%" PRId64 ":%02" PRId64 ":%02" PRId64, total % 86400 / 3600,
                                   total % 3600 / 60, total % 60);
  return days > 0 ? format("%" PRId64 " d ", days) + clock : clock;
}

// How long before the status its camera's newest frame was captured (both times are the daemon's
// clock, so no clock skew between machines enters).
std::string age(std::int64_t status_utime, std::int64_t capture_utime) {
  if (capture_utime == 0) return "never";
  const double ms = static_cast<double>(status_utime - capture_utime) / 1000.0;
  if (std::fabs(ms) < 1000.0) return format("%.0f ms ago", ms);
  return format("%.1f s ago", ms / 1000.0);
}

std::string jsonString(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      case '\r':
        out += "\\r";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          out += format("\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

std::string jsonNumber(double value) {
  return std::isfinite(value) ? format("%.17g", value) : std::string("null");
}

std::string jsonNumber(std::int64_t value) { return format("%" PRId64, value); }

}  // namespace

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
      return format("state %d", state);
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
      return format("state %d", state);
  }
}

std::string formatStatusTable(const occmap::status_t& s) {
  std::string text = "occmapd on " + (s.hostname.empty() ? std::string("?") : s.hostname);
  if (!s.config_file.empty()) text += " (config " + s.config_file + ")";
  text += "\n";
  text +=
      format("  state %s, up %s\n", daemonStateName(s.state).c_str(), uptime(s.uptime_s).c_str());
  text += format("  maps published %" PRId64 " (%.1f maps/s), publish errors %" PRId64 "\n",
                 s.maps_published, s.maps_per_s, s.publish_errors);
  text += format("  fusion per frame set: p50 %.2f ms, p99 %.2f ms\n", s.fusion_p50_ms,
                 s.fusion_p99_ms);
  std::size_t name_width = 6;
  for (const auto& camera : s.cameras) name_width = std::max(name_width, camera.name.size());
  const int w = static_cast<int>(name_width);
  text += format("\n%-*s  %-9s  %10s  %8s  %6s  %s\n", w, "camera", "state", "frames in", "dropped",
                 "fps", "last capture");
  for (const auto& c : s.cameras) {
    text += format("%-*s  %-9s  %10" PRId64 "  %8" PRId64 "  %6.1f  %s\n", w, c.name.c_str(),
                   cameraStateName(c.state).c_str(), c.frames_in, c.frames_dropped, c.fps,
                   age(s.utime, c.last_capture_utime).c_str());
  }
  if (s.cameras.empty()) text += "(no cameras)\n";
  for (const auto& c : s.cameras) {
    if (c.frames_incomplete || c.missing_packets || c.resent_packets || c.underruns ||
        c.reconnects) {
      text += format("%s: %" PRId64 " incomplete frames, %" PRId64 " packets missing, %" PRId64
                     " resent, %" PRId64 " underruns, %d reconnects\n",
                     c.name.c_str(), c.frames_incomplete, c.missing_packets, c.resent_packets,
                     c.underruns, c.reconnects);
    }
    if (!c.last_error.empty()) text += c.name + ": last error: " + c.last_error + "\n";
  }
  return text;
}

std::string formatStatusJson(const occmap::status_t& s) {
  std::string j = "{";
  j += "\"utime\":" + jsonNumber(s.utime);
  j += ",\"request_id\":" + jsonNumber(s.request_id);
  j += ",\"hostname\":" + jsonString(s.hostname);
  j += ",\"config_file\":" + jsonString(s.config_file);
  j += ",\"state\":" + jsonNumber(std::int64_t{s.state});
  j += ",\"state_name\":" + jsonString(daemonStateName(s.state));
  j += ",\"uptime_s\":" + jsonNumber(s.uptime_s);
  j += ",\"maps_published\":" + jsonNumber(s.maps_published);
  j += ",\"publish_errors\":" + jsonNumber(s.publish_errors);
  j += ",\"maps_per_s\":" + jsonNumber(s.maps_per_s);
  j += ",\"fusion_p50_ms\":" + jsonNumber(s.fusion_p50_ms);
  j += ",\"fusion_p99_ms\":" + jsonNumber(s.fusion_p99_ms);
  j += ",\"cameras\":[";
  for (std::size_t k = 0; k < s.cameras.size(); ++k) {
    const auto& c = s.cameras[k];
    if (k > 0) j += ",";
    j += "{\"name\":" + jsonString(c.name);
    j += ",\"source\":" + jsonString(c.source);
    j += ",\"state\":" + jsonNumber(std::int64_t{c.state});
    j += ",\"state_name\":" + jsonString(cameraStateName(c.state));
    j += ",\"frames_in\":" + jsonNumber(c.frames_in);
    j += ",\"frames_dropped\":" + jsonNumber(c.frames_dropped);
    j += ",\"fps\":" + jsonNumber(c.fps);
    j += ",\"last_capture_utime\":" + jsonNumber(c.last_capture_utime);
    j += ",\"frames_incomplete\":" + jsonNumber(c.frames_incomplete);
    j += ",\"missing_packets\":" + jsonNumber(c.missing_packets);
    j += ",\"resent_packets\":" + jsonNumber(c.resent_packets);
    j += ",\"underruns\":" + jsonNumber(c.underruns);
    j += ",\"reconnects\":" + jsonNumber(std::int64_t{c.reconnects});
    j += ",\"last_error\":" + jsonString(c.last_error) + "}";
  }
  return j + "]}";
}

}  // namespace occmap
