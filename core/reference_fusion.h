#pragma once

#include <span>

#include "core/carve_table.h"
#include "core/image.h"
#include "core/map_geometry.h"

namespace occmap {

// One camera's part of a frame set.
struct CameraFrame {
  const CarveTable* table = nullptr;
  ImageView live;        // empty: the camera is down for this frame set
  ImageView background;  // the empty scene, the stream's size
  int threshold = 20;
};

// Paper eqs. 14-15: a pixel is unchanged, and its ray clear, when |live - background| < threshold.
inline bool unchanged(const CameraFrame& camera, std::uint32_t pixel) {
  const int width = camera.live.width;
  const int u = static_cast<int>(pixel % static_cast<std::uint32_t>(width));
  const int v = static_cast<int>(pixel / static_cast<std::uint32_t>(width));
  const int difference = int{camera.live.at(u, v)} - int{camera.background.at(u, v)};
  return (difference < 0 ? -difference : difference) < camera.threshold;
}

// The yardstick every fast kernel is tested against: cell by cell, camera by camera, straight from
// the definitions. A cell is FREE when some live camera that sees it clears it (by its table's
// rule), OCCUPIED when a live camera sees it and none clears it, UNSEEN when no live camera sees
// it. Throws std::invalid_argument when an image's size differs from its table's.
OccupancyMap fuseReference(const MapGeometry& map, std::span<const CameraFrame> cameras);

}  // namespace occmap
