#include "core/zones.h"

#include <stdexcept>

namespace occmap {

std::string_view zoneStateName(ZoneState state) {
  switch (state) {
    case ZoneState::kFree:
      return "free";
    case ZoneState::kOccupied:
      return "occupied";
    case ZoneState::kUnseen:
      return "unseen";
  }
  return "unseen";
}

std::vector<std::uint32_t> cellsInside(const MapGeometry& map,
                                       std::span<const Eigen::Vector2d> polygon_m) {
  std::vector<std::uint32_t> inside;
  for (int row = 0; row < map.height; ++row) {
    for (int column = 0; column < map.width; ++column) {
      const Eigen::Vector2d p = map.cellCentre(row, column);
      bool in = false;
      for (std::size_t i = 0, j = polygon_m.size() - 1; i < polygon_m.size(); j = i++) {
        const Eigen::Vector2d& a = polygon_m[i];
        const Eigen::Vector2d& b = polygon_m[j];
        if ((a.y() > p.y()) != (b.y() > p.y()) &&
            p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x()) {
          in = !in;
        }
      }
      if (in) inside.push_back(static_cast<std::uint32_t>(map.index(row, column)));
    }
  }
  return inside;
}

Zones::Zones(const MapGeometry& map, std::span<const ZoneSpec> zones)
    : cell_count_(map.cellCount()) {
  for (const ZoneSpec& zone : zones) {
    if (zone.polygon_m.size() < 3) {
      throw std::invalid_argument("zone " + zone.name + " has fewer than 3 corners");
    }
    cells_.push_back(cellsInside(map, zone.polygon_m));
    if (cells_.back().empty()) {
      throw std::invalid_argument("zone " + zone.name + " holds no cell centre of the map");
    }
  }
  status_.resize(cells_.size());
}

const std::vector<ZoneStatus>& Zones::update(std::span<const CellState> cells, double time_s) {
  if (cells.size() != cell_count_) throw std::invalid_argument("Zones: the map is not the zones'");
  for (std::size_t z = 0; z < cells_.size(); ++z) {
    ZoneStatus& status = status_[z];
    status.cells = cells_[z].size();
    status.occupied_cells = 0;
    status.unseen_cells = 0;
    for (const std::uint32_t cell : cells_[z]) {
      status.occupied_cells += cells[cell] == CellState::kOccupied;
      status.unseen_cells += cells[cell] == CellState::kUnseen;
    }
    const ZoneState state = status.occupied_cells > 0 ? ZoneState::kOccupied
                            : status.unseen_cells > 0 ? ZoneState::kUnseen
                                                      : ZoneState::kFree;
    if (!started_ || state != status.state) {
      status.state = state;
      status.changed_s = time_s;
    }
  }
  started_ = true;
  return status_;
}

}  // namespace occmap
