// Zones on the floor and their state per map (core/zones.h).
#include "core/zones.h"

#include <vector>

#include <gtest/gtest.h>

namespace occmap {
namespace {

MapGeometry tenByTen() {
  MapGeometry map;
  map.origin_x_m = 0.0;
  map.origin_y_m = 0.0;
  map.cell_size_m = 0.1;
  map.width = 10;
  map.height = 10;
  return map;
}

TEST(Zones, HoldTheCellsWhoseCentresLieInside) {
  const MapGeometry map = tenByTen();
  // A square over cells 2..4 of rows and columns, and a triangle.
  const std::vector<Eigen::Vector2d> square = {{0.2, 0.2}, {0.5, 0.2}, {0.5, 0.5}, {0.2, 0.5}};
  EXPECT_EQ(cellsInside(map, square).size(), 9u);
  const std::vector<Eigen::Vector2d> triangle = {{0.0, 0.0}, {1.0, 0.0}, {0.0, 1.0}};
  const std::vector<std::uint32_t> inside = cellsInside(map, triangle);
  EXPECT_EQ(inside.size(), 45u) << "centres (i + 0.5) / 10 with i + j < 9";
  const std::vector<Eigen::Vector2d> away = {{5, 5}, {6, 5}, {6, 6}};
  EXPECT_TRUE(cellsInside(map, away).empty());
  EXPECT_THROW(Zones(map, std::vector<ZoneSpec>{{"away", away}}), std::invalid_argument);
  EXPECT_THROW(Zones(map, std::vector<ZoneSpec>{{"line", {{0, 0}, {1, 1}}}}),
               std::invalid_argument);
}

TEST(Zones, AreOccupiedByAnyCellUnseenWhenSomeAreAndFreeOnlyWhenAllAre) {
  const MapGeometry map = tenByTen();
  Zones zones(map,
              std::vector<ZoneSpec>{{"cell", {{0.2, 0.2}, {0.5, 0.2}, {0.5, 0.5}, {0.2, 0.5}}}});
  std::vector<CellState> cells(map.cellCount(), CellState::kFree);
  EXPECT_EQ(zones.update(cells, 0.0)[0].state, ZoneState::kFree);
  cells[static_cast<std::size_t>(map.index(3, 3))] = CellState::kUnseen;
  const ZoneStatus unseen = zones.update(cells, 1.0)[0];
  EXPECT_EQ(unseen.state, ZoneState::kUnseen);
  EXPECT_EQ(unseen.unseen_cells, 1u);
  EXPECT_DOUBLE_EQ(unseen.changed_s, 1.0);
  cells[static_cast<std::size_t>(map.index(2, 4))] = CellState::kOccupied;
  EXPECT_EQ(zones.update(cells, 2.0)[0].state, ZoneState::kOccupied) << "occupied over unseen";
  const ZoneStatus still = zones.update(cells, 3.5)[0];
  EXPECT_EQ(still.state, ZoneState::kOccupied);
  EXPECT_DOUBLE_EQ(still.changed_s, 2.0) << "the time it changed, not the last map's";
  // A cell outside the zone changes nothing.
  std::fill(cells.begin(), cells.end(), CellState::kFree);
  cells[static_cast<std::size_t>(map.index(8, 8))] = CellState::kOccupied;
  EXPECT_EQ(zones.update(cells, 4.0)[0].state, ZoneState::kFree);
  EXPECT_EQ(zoneStateName(ZoneState::kUnseen), "unseen");
}

}  // namespace
}  // namespace occmap
