// Zones on the floor and their state per map (core/zones.h).
#include "core/zones.h"

#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "corner_cameras.h"

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

TEST(Zones, CountEveryCellOfAnyShapeAsTheCellsInsideSay) {
  // Runs of cells along rows, counted 8 at a time: against a plain count, on shapes whose rows
  // start and end anywhere, with every state at random.
  MapGeometry map = tenByTen();
  map.width = 97;
  map.height = 61;
  const std::vector<ZoneSpec> specs = {
      {"triangle", {{0.05, 0.1}, {9.6, 0.3}, {2.0, 6.0}}},
      {"sliver", {{1.23, 2.0}, {1.31, 2.0}, {1.31, 5.5}, {1.23, 5.5}}},
      {"all", {{0, 0}, {9.7, 0}, {9.7, 6.1}, {0, 6.1}}}};
  Zones zones(map, specs);
  std::mt19937 random(7);
  std::vector<CellState> cells(map.cellCount());
  for (int round = 0; round < 20; ++round) {
    for (CellState& cell : cells) cell = static_cast<CellState>(random() % 3);
    const std::vector<ZoneStatus>& status = zones.update(cells, round);
    for (std::size_t z = 0; z < specs.size(); ++z) {
      std::size_t occupied = 0, unseen = 0;
      for (const std::uint32_t cell : zones.cells(z)) {
        occupied += cells[cell] == CellState::kOccupied;
        unseen += cells[cell] == CellState::kUnseen;
      }
      ASSERT_EQ(status[z].occupied_cells, occupied) << specs[z].name;
      ASSERT_EQ(status[z].unseen_cells, unseen) << specs[z].name;
    }
  }
  EXPECT_EQ(zones.cells(2).size(), map.cellCount());
}

// One camera at a corner of a 6 x 6 m floor, 3 m up; a person found at (2, 2), 2.8 m across the
// floor from below it, so that the floor straight behind them lies in their box.
struct HiddenRoom {
  MapGeometry map = testing::cornerRoomMap();
  std::vector<Camera> cameras;
  FootprintSettings box;  // 0.5 x 1.75 m
  Eigen::Vector2d person{2.0, 2.0};
  Eigen::Vector2d away;  // unit vector, from below the camera through the person
  HiddenRoom() {
    cameras.push_back(testing::cornerCamera({0.0, 0.0, 3.0}));
    away = person.normalized();
  }
  // A zone of the one cell holding p.
  std::vector<ZoneSpec> spot(const Eigen::Vector2d& p) const {
    const double s = map.cell_size_m;
    const Eigen::Vector2d c = ((p / s).array().floor() + 0.5).matrix() * s;  // its centre
    const double h = 0.6 * s;
    return {{"spot",
             {{c.x() - h, c.y() - h},
              {c.x() + h, c.y() - h},
              {c.x() + h, c.y() + h},
              {c.x() - h, c.y() + h}}}};
  }
  // The zone's state on a map where its cell alone is occupied.
  ZoneStatus stateWithOccupied(const Eigen::Vector2d& p, std::span<const Detection> found) const {
    Zones zones(map, spot(p), cameras, box, 0.3);
    std::vector<CellState> cells(map.cellCount(), CellState::kFree);
    for (const std::uint32_t cell : zones.cells(0)) cells[cell] = CellState::kOccupied;
    return zones.update(cells, 0.0, found)[0];
  }
};

TEST(Zones, CallTheFloorHiddenBehindSomeoneFoundUnseenNeverFree) {
  const HiddenRoom room;
  const std::vector<Detection> found = {{room.person.x(), room.person.y(), 0.2, 0.5, 0.0}};
  const Eigen::Vector2d behind = room.person + 1.0 * room.away;
  // Nobody found: an occupied cell is something standing there.
  EXPECT_EQ(room.stateWithOccupied(behind, {}).state, ZoneState::kOccupied);
  // 1 m behind the person found, in their box: what is there cannot be told.
  const ZoneStatus hidden = room.stateWithOccupied(behind, found);
  EXPECT_EQ(hidden.state, ZoneState::kUnseen);
  EXPECT_TRUE(hidden.hidden_only);
  EXPECT_EQ(hidden.occupied_cells, 1u) << "the counts stay the map's";
  // Beside the person, 1 m to the side, the camera sees past them: occupied.
  const Eigen::Vector2d side(-room.away.y(), room.away.x());
  EXPECT_EQ(room.stateWithOccupied(room.person + 1.0 * side, found).state, ZoneState::kOccupied);
  // In front of them, 1.5 m nearer the camera: occupied.
  EXPECT_EQ(room.stateWithOccupied(room.person - 1.5 * room.away, found).state,
            ZoneState::kOccupied);
  // Far behind, past the top of their box (1.75 m tall, the camera 3 m up): occupied.
  EXPECT_EQ(room.stateWithOccupied(room.person + 5.0 * room.away, found).state,
            ZoneState::kOccupied);
  // On their own footprint (within half the box's width): theirs, occupied.
  EXPECT_EQ(room.stateWithOccupied(room.person + 0.15 * side, found).state, ZoneState::kOccupied);
  // Just past their footprint, up to a box's width from them: the edge of the person found
  // (cameras a frame apart, the carving's column), unseen.
  EXPECT_EQ(room.stateWithOccupied(room.person + 0.4 * side, found).state, ZoneState::kUnseen);
  // A found person's box only hides: with every cell free the zone is free.
  Zones zones(room.map, room.spot(behind), room.cameras, room.box, 0.3);
  const std::vector<CellState> free(room.map.cellCount(), CellState::kFree);
  EXPECT_EQ(zones.update(free, 0.0, found)[0].state, ZoneState::kFree);
}

TEST(Zones, TellHiddenFloorOnlyWhenEveryCameraThatSeesItHasSomeoneFoundInTheWay) {
  HiddenRoom room;
  const std::vector<Detection> found = {{room.person.x(), room.person.y(), 0.2, 0.5, 0.0}};
  const Eigen::Vector2d behind = room.person + 1.0 * room.away;
  ASSERT_EQ(room.stateWithOccupied(behind, found).state, ZoneState::kUnseen);
  // A second camera, across the floor, sees the spot with nobody in the way.
  room.cameras.push_back(testing::cornerCamera({6.0, 0.0, 3.0}));
  EXPECT_EQ(room.stateWithOccupied(behind, found).state, ZoneState::kOccupied);
  // Someone found in its way too: hidden from both.
  const Eigen::Vector2d second_below(6.0, 0.0);
  const Eigen::Vector2d second = behind + 1.0 * (second_below - behind).normalized();
  const std::vector<Detection> two = {found[0], {second.x(), second.y(), 0.2, 0.5, 0.0}};
  EXPECT_EQ(room.stateWithOccupied(behind, two).state, ZoneState::kUnseen);
}

// A camera re-posed after a knock (core/repose.h) judges the hidden floor from its new pose once
// handed over: here moved to the far corner, from where the person found is no longer in the way.
TEST(Zones, AReposedCameraJudgesTheHiddenFloorFromItsNewPose) {
  const HiddenRoom room;
  const std::vector<Detection> found = {{room.person.x(), room.person.y(), 0.2, 0.5, 0.0}};
  const Eigen::Vector2d behind = room.person + 1.0 * room.away;
  Zones zones(room.map, room.spot(behind), room.cameras, room.box, 0.3);
  ASSERT_TRUE(zones.tellsHiddenFloor());
  std::vector<CellState> cells(room.map.cellCount(), CellState::kFree);
  for (const std::uint32_t cell : zones.cells(0)) cells[cell] = CellState::kOccupied;
  ASSERT_EQ(zones.update(cells, 0.0, found)[0].state, ZoneState::kUnseen);
  const Camera moved = testing::cornerCamera({6.0, 0.0, 3.0});
  const std::vector<HiddenFloor::Rectangle> sights = zones.sightsOf(moved);
  ASSERT_EQ(sights.size(), zones.cells(0).size());
  EXPECT_THROW(zones.replaceCamera(0, Camera(moved), std::span(sights).first(0)),
               std::invalid_argument);
  zones.replaceCamera(0, Camera(moved), sights);
  EXPECT_EQ(zones.update(cells, 0.1, found)[0].state, ZoneState::kOccupied);
  // Someone found in its new line of sight hides the spot again.
  const Eigen::Vector2d second = behind + 1.0 * (Eigen::Vector2d(6.0, 0.0) - behind).normalized();
  const std::vector<Detection> in_the_way = {{second.x(), second.y(), 0.2, 0.5, 0.0}};
  EXPECT_EQ(zones.update(cells, 0.2, in_the_way)[0].state, ZoneState::kUnseen);
  // Zones without the cameras have nothing to re-pose.
  Zones plain(room.map, room.spot(behind));
  EXPECT_FALSE(plain.tellsHiddenFloor());
  EXPECT_TRUE(plain.sightsOf(moved).empty());
}

}  // namespace
}  // namespace occmap
