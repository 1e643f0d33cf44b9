#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

namespace occmap {

// The floor raster (ARCHITECTURE.md, Conventions): `origin` is the outer corner of cell (0, 0);
// cell (row r, column c) has its centre at x = origin_x + (c + 0.5) cell, y = origin_y + (r + 0.5)
// cell. Row-major, row 0 = smallest y. All lengths in metres.
struct MapGeometry {
  double origin_x_m = -0.5;
  double origin_y_m = -1.5;
  double cell_size_m = 0.02;
  int width = 512;   // columns
  int height = 512;  // rows

  std::size_t cellCount() const {
    return static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  }
  int index(int row, int column) const { return row * width + column; }
  Eigen::Vector2d cellCentre(int row, int column) const {
    return {origin_x_m + (column + 0.5) * cell_size_m, origin_y_m + (row + 0.5) * cell_size_m};
  }
  // The centre of the cell at `cell` (row-major index, as index() gives it).
  Eigen::Vector2d cellCentre(std::size_t cell) const {
    const auto w = static_cast<std::size_t>(width);
    return cellCentre(static_cast<int>(cell / w), static_cast<int>(cell % w));
  }
  // The cell containing floor point (x, y), if it lies on the map.
  std::optional<int> cellAt(double x, double y) const;

  // The very same raster (a map received is compared with the one expected: exact, no tolerance).
  bool operator==(const MapGeometry&) const = default;
};

// What the map says of one cell. The values are those of map_frame_t and of the PNG maps' meaning.
enum class CellState : std::uint8_t {
  kFree = 0,      // some live camera cleared it
  kOccupied = 1,  // seen by a live camera, cleared by none
  kUnseen = 2,    // no live camera has it in view
};

// One map frame's cells, row-major as MapGeometry says.
struct OccupancyMap {
  MapGeometry geometry;
  std::vector<CellState> cells;

  explicit OccupancyMap(const MapGeometry& g, CellState fill = CellState::kUnseen)
      : geometry(g), cells(g.cellCount(), fill) {}
  CellState at(int row, int column) const {
    return cells[static_cast<std::size_t>(geometry.index(row, column))];
  }
};

// PNG grey levels of the map images: 0 free, 255 occupied, 128 unseen.
constexpr std::uint8_t greyLevel(CellState state) {
  return state == CellState::kFree ? 0 : state == CellState::kOccupied ? 255 : 128;
}

}  // namespace occmap
