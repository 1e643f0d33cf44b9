#include "tools/footprint_pictures.h"

#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "tools/pictures.h"

namespace occmap::tools {
namespace {

// Whether a point from the network may be drawn: finite, and on the map or within one map's size
// around it. (OpenCV draws in fixed point: coordinates near INT_MAX would overflow.)
bool nearMap(const MapGeometry& map, double x, double y) {
  const double width_m = map.width * map.cell_size_m;
  const double height_m = map.height * map.cell_size_m;
  return std::isfinite(x) && std::isfinite(y) && x >= map.origin_x_m - width_m &&
         x <= map.origin_x_m + 2 * width_m && y >= map.origin_y_m - height_m &&
         y <= map.origin_y_m + 2 * height_m;
}

// Text with a white halo, as the scale bar's: readable on every floor colour.
void drawLabel(cv::Mat& plan, const std::string& text, cv::Point at, const cv::Scalar& colour) {
  cv::putText(plan, text, at, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(255, 255, 255), 3,
              cv::LINE_AA);
  cv::putText(plan, text, at, cv::FONT_HERSHEY_SIMPLEX, 0.45, colour, 1, cv::LINE_AA);
}

}  // namespace

cv::Scalar zoneStateColour(std::int8_t state) {
  switch (state) {
    case occmap::zone_t::FREE:
      return kZoneFreeColour;
    case occmap::zone_t::OCCUPIED:
      return kZoneOccupiedColour;
    case occmap::zone_t::UNSEEN:
      return kZoneUnseenColour;
    default:
      return kZoneUnknownColour;
  }
}

std::string printableName(const std::string& name) {
  constexpr std::size_t kLongest = 32;
  std::string out;
  for (const char c : name) {
    if (out.size() == kLongest) break;
    out += c >= 0x20 && c <= 0x7E ? c : '?';
  }
  return out;
}

void drawZones(cv::Mat& plan, const MapGeometry& map, int pixels_per_cell,
               const occmap::zones_t& zones) {
  std::vector<cv::Point> corners;
  for (const occmap::zone_t& zone : zones.zones) {
    corners.clear();
    for (std::size_t k = 0; k < zone.corner_x_m.size() && k < zone.corner_y_m.size(); ++k) {
      if (!nearMap(map, zone.corner_x_m[k], zone.corner_y_m[k])) break;
      corners.push_back(
          floorPlanPoint(map, pixels_per_cell, zone.corner_x_m[k], zone.corner_y_m[k]));
    }
    // A zone with a corner off the map, or fewer than 3, is no polygon that can be drawn.
    if (corners.size() < 3 || corners.size() != zone.corner_x_m.size()) continue;
    const cv::Scalar colour = zoneStateColour(zone.state);
    // LINE_8, not anti-aliased: the outline is its state's colour exactly.
    cv::polylines(plan, corners, true, colour, kZoneLineThicknessPx, cv::LINE_8);
    // The label just above the polygon (below it at the picture's top), never across its edges.
    const cv::Rect box = cv::boundingRect(corners);
    const cv::Point at =
        box.y >= 20 ? cv::Point(box.x, box.y - 7) : cv::Point(box.x, box.y + box.height + 16);
    drawLabel(plan, printableName(zone.name) + " " + zoneStateText(zone.state), at, colour);
  }
}

void drawTracks(cv::Mat& plan, const MapGeometry& map, int pixels_per_cell,
                const occmap::tracks_t& tracks) {
  for (const occmap::footprint_t& footprint : tracks.footprints) {
    if (!nearMap(map, footprint.x_m, footprint.y_m)) continue;
    cv::circle(plan, floorPlanPoint(map, pixels_per_cell, footprint.x_m, footprint.y_m),
               kFootprintRadiusPx, kFootprintColour, 2, cv::LINE_8);
  }
  for (const occmap::track_t& track : tracks.tracks) {
    if (!nearMap(map, track.x_m, track.y_m)) continue;
    const cv::Point at = floorPlanPoint(map, pixels_per_cell, track.x_m, track.y_m);
    const double end_x = track.x_m + track.vx_m_s * kTrackArrowSeconds;
    const double end_y = track.y_m + track.vy_m_s * kTrackArrowSeconds;
    if (nearMap(map, end_x, end_y)) {
      const cv::Point end = floorPlanPoint(map, pixels_per_cell, end_x, end_y);
      if (end != at) cv::arrowedLine(plan, at, end, kTrackColour, 2, cv::LINE_8, 0, 0.3);
    }
    cv::circle(plan, at, kTrackDotRadiusPx, kTrackColour, cv::FILLED, cv::LINE_8);
    drawLabel(plan, std::to_string(track.id), at + cv::Point(8, -8), kTrackColour);
  }
}

}  // namespace occmap::tools
