#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "core/camera.h"
#include "core/image.h"
#include "core/map_geometry.h"

namespace occmap {

// How a camera's pixels decide one of its cells.
enum class CarveRule : std::uint8_t {
  // column_height_m = 0, the paper's floor-point carving: the cell is cleared when any of its
  // pixels
  // is unchanged (a clear ray reaches the floor inside the cell).
  kAnyPixel,
  // column_height_m > 0, column carving: the cell is cleared only when every pixel on the image of
  // its
  // vertical column, from the floor up to column_height_m, is unchanged.
  kEveryPixel,
};

// One camera's look-up table from map cells to the stream pixels that decide them, computed once
// from calibration + map geometry (+ floor mask), never in the frame loop.
//
// Floor mode (column_height_m = 0) holds the paper's table, each floor pixel's centre to the cell
// its ray meets on the floor, and more: every cell whose centre projects into a floor pixel also
// gets that pixel, so far from the camera, where cells fall between pixel centres, no cell the
// camera sees is left without a pixel (the paper's holes). Column mode (column_height_m > 0) gives
// every such cell the pixels crossed by the image of its vertical column (see buildCarveTable).
//
// A camera sees a cell when some floor pixel decides it: always when the cell's centre projects
// into an in-bounds floor pixel (no holes), and in floor mode also when a floor pixel's centre ray
// meets the floor inside the cell (at the image's and the mask's borders).
class CarveTable {
 public:
  CarveTable() = default;
  CarveTable(CarveRule rule, const MapGeometry& map, int image_width, int image_height,
             std::vector<std::uint32_t> cell_offsets, std::vector<std::uint32_t> cell_pixels);

  CarveRule rule() const { return rule_; }
  const MapGeometry& map() const { return map_; }
  int imageWidth() const { return image_width_; }
  int imageHeight() const { return image_height_; }

  bool sees(std::size_t cell) const { return offsets_[cell + 1] > offsets_[cell]; }
  // Stream pixel indices (v * width + u) that decide the cell, ascending, without repeats.
  std::span<const std::uint32_t> pixelsOf(std::size_t cell) const {
    return {pixels_.data() + offsets_[cell], pixels_.data() + offsets_[cell + 1]};
  }
  std::size_t cellsInView() const;
  std::size_t entries() const { return pixels_.size(); }

 private:
  CarveRule rule_ = CarveRule::kAnyPixel;
  MapGeometry map_;
  int image_width_ = 0;
  int image_height_ = 0;
  std::vector<std::uint32_t> offsets_;  // map_.cellCount() + 1 entries (CSR)
  std::vector<std::uint32_t> pixels_;
};

// Column carving follows the image of each cell's column from the floor up to ceil(h / step) * step
// and takes every pixel it crosses; the knots it follows sit at heights that depend on the cell
// only, never on h, so a lower column's pixels are always a subset of a higher one's: carving is
// monotone in column_height_m, and heights are honoured rounded up to the step (1 cm).
inline constexpr double kColumnStepM = 0.01;

// `floor_mask`, if not empty, has the stream's size; non-zero marks floor pixels, the only ones
// that may clear a cell. Throws std::invalid_argument on a mask of another size or a negative
// height.
CarveTable buildCarveTable(const Camera& camera, const MapGeometry& map, double column_height_m,
                           ImageView floor_mask = {});

// Every stream pixel whose square the straight segment from a to b (stream pixel coordinates)
// passes through, in order; pixels out of bounds are skipped. Exposed for tests.
void forEachPixelOnSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b, int width,
                           int height, std::vector<std::uint32_t>& out);

}  // namespace occmap
