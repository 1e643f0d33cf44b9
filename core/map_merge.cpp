#include "core/map_merge.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace occmap {
namespace {

bool sameGeometry(const MapGeometry& a, const MapGeometry& b) {
  return a.origin_x_m == b.origin_x_m && a.origin_y_m == b.origin_y_m &&
         a.cell_size_m == b.cell_size_m && a.width == b.width && a.height == b.height;
}

}  // namespace

MapMerger::MapMerger(const MapGeometry& merged, const std::vector<MapGeometry>& inputs)
    : merged_(merged) {
  for (const MapGeometry& geometry : inputs) {
    Input input;
    input.geometry = geometry;
    input.same = sameGeometry(geometry, merged);
    if (!input.same) {
      input.cell.resize(merged.cellCount());
      for (std::size_t i = 0; i < merged.cellCount(); ++i) {
        const Eigen::Vector2d centre = merged.cellCentre(i);
        input.cell[i] = geometry.cellAt(centre.x(), centre.y()).value_or(-1);
      }
    }
    inputs_.push_back(std::move(input));
  }
}

void MapMerger::merge(const std::vector<const OccupancyMap*>& inputs, OccupancyMap& out) const {
  if (inputs.size() != inputs_.size() || out.cells.size() != merged_.cellCount()) {
    throw std::invalid_argument("MapMerger::merge: " + std::to_string(inputs.size()) +
                                " maps for " + std::to_string(inputs_.size()) +
                                " inputs, or an output of another geometry");
  }
  // Unseen until some input sees the cell; occupied once one does; free once one frees it, which no
  // other input undoes: the same whatever the order of the inputs.
  std::fill(out.cells.begin(), out.cells.end(), CellState::kUnseen);
  for (std::size_t k = 0; k < inputs_.size(); ++k) {
    const OccupancyMap* map = inputs[k];
    if (map == nullptr) continue;  // down: it sees nothing
    const Input& input = inputs_[k];
    if (map->cells.size() != input.geometry.cellCount()) {
      throw std::invalid_argument("MapMerger::merge: input " + std::to_string(k) +
                                  " is not of the geometry it was given");
    }
    for (std::size_t i = 0; i < out.cells.size(); ++i) {
      const std::int32_t cell = input.same ? static_cast<std::int32_t>(i) : input.cell[i];
      if (cell < 0) continue;
      const CellState state = map->cells[static_cast<std::size_t>(cell)];
      CellState& merged = out.cells[i];
      if (state == CellState::kFree) {
        merged = CellState::kFree;
      } else if (state == CellState::kOccupied && merged == CellState::kUnseen) {
        merged = CellState::kOccupied;
      }
    }
  }
}

}  // namespace occmap
