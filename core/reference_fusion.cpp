#include "core/reference_fusion.h"

#include <stdexcept>

namespace occmap {
namespace {

bool clears(const CameraFrame& camera, std::size_t cell) {
  const std::span<const std::uint32_t> pixels = camera.table->pixelsOf(cell);
  if (camera.table->rule() == CarveRule::kAnyPixel) {
    for (const std::uint32_t pixel : pixels) {
      if (unchanged(camera, pixel)) return true;
    }
    return false;
  }
  for (const std::uint32_t pixel : pixels) {
    if (!unchanged(camera, pixel)) return false;
  }
  return true;
}

void checkSizes(const MapGeometry& map, const CameraFrame& camera) {
  const CarveTable& table = *camera.table;
  if (table.map().cellCount() != map.cellCount()) {
    throw std::invalid_argument("carve table built for another map");
  }
  if (camera.live.empty()) return;
  for (const ImageView* image : {&camera.live, &camera.background}) {
    if (image->width != table.imageWidth() || image->height != table.imageHeight()) {
      throw std::invalid_argument("image size differs from the carve table's");
    }
  }
}

}  // namespace

OccupancyMap fuseReference(const MapGeometry& map, std::span<const CameraFrame> cameras) {
  for (const CameraFrame& camera : cameras) checkSizes(map, camera);
  OccupancyMap result(map, CellState::kUnseen);
  for (std::size_t cell = 0; cell < map.cellCount(); ++cell) {
    CellState state = CellState::kUnseen;
    for (const CameraFrame& camera : cameras) {
      if (camera.live.empty() || !camera.table->sees(cell)) continue;
      if (clears(camera, cell)) {
        state = CellState::kFree;
        break;
      }
      state = CellState::kOccupied;
    }
    result.cells[cell] = state;
  }
  return result;
}

}  // namespace occmap
