#pragma once
// What occmapd finds on its maps (lcmtypes/zones_t.lcm, tracks_t.lcm), drawn over the floor plans
// of `occmap view` (tools/pictures.h) at the places floorPlanPoint gives: each zone's outline in
// its state's colour with its name and state, each footprint as a hollow circle, each track as a
// dot with its id and an arrow of one second's motion. Everything drawn came from the network: a
// point that is not finite or lies far off the map is left out, and names are shown in printable
// ASCII only.

#include <cstdint>
#include <string>

#include <occmap/tracks_t.hpp>
#include <occmap/zones_t.hpp>
#include <opencv2/core.hpp>

#include "core/map_geometry.h"
#include "transport/status_text.h"  // zoneStateText

namespace occmap::tools {

// Colours (BGR), none of them one of the floor plan's (white, near black, blue-grey).
inline const cv::Scalar kZoneFreeColour{60, 170, 60};      // green
inline const cv::Scalar kZoneOccupiedColour{40, 40, 220};  // red
inline const cv::Scalar kZoneUnseenColour{0, 170, 255};    // amber
inline const cv::Scalar kZoneUnknownColour{200, 60, 200};  // a state this viewer does not know
inline const cv::Scalar kTrackColour{200, 90, 0};          // blue
inline const cv::Scalar kFootprintColour{0, 140, 140};     // olive
inline constexpr int kFootprintRadiusPx = 9;               // thickness 2
inline constexpr int kTrackDotRadiusPx = 5;                // filled
inline constexpr int kZoneLineThicknessPx = 3;             // centred on the polygon's edges
inline constexpr double kTrackArrowSeconds = 1.0;          // the arrow shows this much motion

cv::Scalar zoneStateColour(std::int8_t state);
// A name from the network fit for a picture (OpenCV's fonts draw ASCII only): printable ASCII,
// anything else '?', at most 32 characters. On a terminal, terminalText (transport/status_text.h).
std::string printableName(const std::string& name);

// The zones' outlines and labels, the footprints and the tracks, over a floor plan of `map`.
void drawZones(cv::Mat& plan, const MapGeometry& map, int pixels_per_cell,
               const occmap::zones_t& zones);
void drawTracks(cv::Mat& plan, const MapGeometry& map, int pixels_per_cell,
                const occmap::tracks_t& tracks);

}  // namespace occmap::tools
