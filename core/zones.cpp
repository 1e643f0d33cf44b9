#include "core/zones.h"

#include <cstring>
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

namespace {

// Adds the occupied and the unseen among n cells: 8 at a time, as bytes whose bit 0 says
// occupied and bit 1 unseen (CellState's values), summed by one multiplication each.
void countStates(const CellState* cells, std::size_t n, std::size_t& occupied,
                 std::size_t& unseen) {
  static_assert(static_cast<int>(CellState::kOccupied) == 1 &&
                static_cast<int>(CellState::kUnseen) == 2 && sizeof(CellState) == 1);
  constexpr std::uint64_t kOnes = 0x0101010101010101ull;
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    std::uint64_t word;
    std::memcpy(&word, cells + i, 8);
    occupied += static_cast<std::size_t>(((word & kOnes) * kOnes) >> 56);
    unseen += static_cast<std::size_t>((((word >> 1) & kOnes) * kOnes) >> 56);
  }
  for (; i < n; ++i) {
    occupied += cells[i] == CellState::kOccupied;
    unseen += cells[i] == CellState::kUnseen;
  }
}

}  // namespace

Zones::Zones(const MapGeometry& map, std::span<const ZoneSpec> zones)
    : cell_count_(map.cellCount()) {
  std::uint32_t before = 0;  // the cells of the zones before this one
  for (const ZoneSpec& zone : zones) {
    if (zone.polygon_m.size() < 3) {
      throw std::invalid_argument("zone " + zone.name + " has fewer than 3 corners");
    }
    cells_.push_back(cellsInside(map, zone.polygon_m));
    if (cells_.back().empty()) {
      throw std::invalid_argument("zone " + zone.name + " holds no cell centre of the map");
    }
    std::vector<Run>& runs = runs_.emplace_back();
    const std::vector<std::uint32_t>& cells = cells_.back();
    for (std::size_t i = 0; i < cells.size(); ++i) {
      const bool joins = !runs.empty() && cells[i] == cells[i - 1] + 1 &&
                         cells[i] % static_cast<std::uint32_t>(map.width) != 0;
      if (joins) {
        ++runs.back().count;
      } else {
        runs.push_back(Run{cells[i], 1, before + static_cast<std::uint32_t>(i)});
      }
    }
    before += static_cast<std::uint32_t>(cells.size());
  }
  status_.resize(cells_.size());
}

Zones::Zones(const MapGeometry& map, std::span<const ZoneSpec> zones,
             std::span<const Camera> cameras, const FootprintSettings& box, double column_height_m)
    : Zones(map, zones) {
  std::vector<std::uint32_t> every;
  for (const std::vector<std::uint32_t>& cells : cells_) {
    every.insert(every.end(), cells.begin(), cells.end());
  }
  hidden_.emplace(map, every, cameras, box, column_height_m);
}

const std::vector<ZoneStatus>& Zones::update(std::span<const CellState> cells, double time_s,
                                             std::span<const Detection> found) {
  if (cells.size() != cell_count_) throw std::invalid_argument("Zones: the map is not the zones'");
  const bool judge_hidden = hidden_ && !found.empty();
  bool found_set = false;  // the people found handed to hidden_ once a map, when a zone asks
  for (std::size_t z = 0; z < cells_.size(); ++z) {
    ZoneStatus& status = status_[z];
    status.cells = cells_[z].size();
    status.occupied_cells = 0;
    status.unseen_cells = 0;
    std::size_t first_run = SIZE_MAX;  // holding an occupied cell
    for (std::size_t r = 0; r < runs_[z].size(); ++r) {
      const Run& run = runs_[z][r];
      const std::size_t occupied = status.occupied_cells;
      countStates(cells.data() + run.first_cell, run.count, status.occupied_cells,
                  status.unseen_cells);
      if (status.occupied_cells > occupied && first_run == SIZE_MAX) first_run = r;
    }
    // Whether every occupied cell is the floor behind someone found: judged only when some are
    // occupied, and only until one is not (then the zone is occupied whatever the rest are).
    status.hidden_only = false;
    if (judge_hidden && status.occupied_cells > 0) {
      if (!found_set) hidden_->setFound(found);
      found_set = true;
      status.hidden_only = true;
      for (std::size_t r = first_run; r < runs_[z].size() && status.hidden_only; ++r) {
        const Run& run = runs_[z][r];
        for (std::uint32_t j = 0; j < run.count && status.hidden_only; ++j) {
          if (cells[run.first_cell + j] == CellState::kOccupied) {
            status.hidden_only = hidden_->hidden(run.first + j);
          }
        }
      }
    }
    const ZoneState state = status.occupied_cells > 0 && !status.hidden_only ? ZoneState::kOccupied
                            : status.unseen_cells > 0 || status.occupied_cells > 0
                                ? ZoneState::kUnseen
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
