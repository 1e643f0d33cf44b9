// The reference fusion on cases small enough to check by hand.
#include "core/reference_fusion.h"

#include <numbers>

#include <gtest/gtest.h>

#include "core/carve_table.h"
#include "core/tsai_camera.h"

namespace occmap {
namespace {

// A 100x100 camera 2 m above (0, 0) looking straight down; 1 pixel = 1 cm on the floor.
Camera downwardCamera(double x_m = 0.0) {
  TsaiParameters p;
  p.width = p.height = 100;
  p.ncx = p.nfx = 100;
  p.dx = p.dy = p.dpx = p.dpy = 0.01;
  p.focal = 2.0;  // f / h = 2 mm / 2000 mm: 0.01 mm pixel = 10 mm on the floor
  p.cx = p.cy = 49.5;
  p.sx = 1;
  p.rx = std::numbers::pi;  // looking down; world +x = image +u, world +y = image -v
  p.tx = -x_m * 1000.0;
  p.tz = 2000;
  return Camera(std::make_shared<TsaiCamera>(p), LengthUnit::kMillimetre, 100, 100);
}

// A 20x20 map of 5 cm cells from (-0.5, -0.5): the camera sees exactly its middle 1 m x 1 m.
MapGeometry smallMap() {
  MapGeometry map;
  map.origin_x_m = -0.5;
  map.origin_y_m = -0.5;
  map.cell_size_m = 0.05;
  map.width = map.height = 20;
  return map;
}

TEST(ReferenceFusion, UnchangedImageClearsEverythingTheCameraSees) {
  const MapGeometry map = smallMap();
  const CarveTable table = buildCarveTable(downwardCamera(), map, 0.0);
  const Image image(100, 100, 120);
  const CameraFrame frame{&table, image.view(), image.view(), 20};
  const OccupancyMap result = fuseReference(map, std::span(&frame, 1));
  for (CellState state : result.cells) EXPECT_EQ(state, CellState::kFree);
}

TEST(ReferenceFusion, ChangedPixelsLeaveTheirCellsOccupiedAndTheRestFree) {
  const MapGeometry map = smallMap();
  const CarveTable table = buildCarveTable(downwardCamera(), map, 0.0);
  const Image background(100, 100, 120);
  Image live = background;
  // A 20x20 pixel object at u 40..59, v 40..59: floor x in [-0.1, 0.1), y in (-0.1, 0.1].
  for (int v = 40; v < 60; ++v) {
    for (int u = 40; u < 60; ++u) live.at(u, v) = 30;
  }
  // A change below the threshold changes nothing.
  live.at(5, 5) = 120 + 19;
  const CameraFrame frame{&table, live.view(), background.view(), 20};
  const OccupancyMap result = fuseReference(map, std::span(&frame, 1));
  for (int row = 0; row < 20; ++row) {
    for (int column = 0; column < 20; ++column) {
      const bool under = row >= 8 && row < 12 && column >= 8 && column < 12;
      EXPECT_EQ(result.at(row, column), under ? CellState::kOccupied : CellState::kFree)
          << row << "," << column;
    }
  }
}

TEST(ReferenceFusion, ADownCameraLeavesItsCellsUnseenAndAnotherCameraClearsThem) {
  MapGeometry map = smallMap();
  map.width = 40;  // x up to 1.5 m: the second camera, 1 m to the right, sees the right half
  const CarveTable left = buildCarveTable(downwardCamera(0.0), map, 0.0);
  const CarveTable right = buildCarveTable(downwardCamera(1.0), map, 0.0);
  const Image background(100, 100, 120);
  Image live = background;
  for (int v = 0; v < 100; ++v) {
    for (int u = 0; u < 100; ++u) live.at(u, v) = 0;  // the left camera sees only change
  }
  const CameraFrame frames[] = {{&left, live.view(), background.view(), 20},
                                {&right, background.view(), background.view(), 20}};
  const OccupancyMap both = fuseReference(map, frames);
  EXPECT_EQ(both.at(10, 5), CellState::kOccupied);  // left only, changed
  EXPECT_EQ(both.at(10, 30), CellState::kFree);     // right only, unchanged
  const CameraFrame left_down[] = {{&left, ImageView{}, background.view(), 20},
                                   {&right, background.view(), background.view(), 20}};
  const OccupancyMap without_left = fuseReference(map, left_down);
  EXPECT_EQ(without_left.at(10, 5), CellState::kUnseen);
  EXPECT_EQ(without_left.at(10, 30), CellState::kFree);
  const CameraFrame none_live[] = {{&left, ImageView{}, background.view(), 20},
                                   {&right, ImageView{}, background.view(), 20}};
  for (CellState state : fuseReference(map, none_live).cells) EXPECT_EQ(state, CellState::kUnseen);
}

TEST(ReferenceFusion, ColumnCarvingKeepsACellWhoseColumnIsChanged) {
  // A camera off to the side sees a cell's column as a vertical streak above the cell's pixel: a
  // change on the streak (a person's legs) keeps the cell; the floor point alone would clear it.
  TsaiParameters p;
  p.width = p.height = 200;
  p.ncx = p.nfx = 200;
  p.dx = p.dy = p.dpx = p.dpy = 0.01;
  p.focal = 2.0;
  p.cx = p.cy = 99.5;
  p.sx = 1;
  const Pose pose = poseLookingAt({0, -3000, 2000}, {0, 0, 0});
  p.setPose(pose);
  const Camera camera(std::make_shared<TsaiCamera>(p), LengthUnit::kMillimetre, 200, 200);
  MapGeometry map = smallMap();
  const CarveTable floor = buildCarveTable(camera, map, 0.0);
  const CarveTable column = buildCarveTable(camera, map, 0.5);
  const Image background(200, 200, 120);
  Image live = background;
  // Change the image of the point 0.3 m above the centre of cell (10, 10), and nothing else.
  const Eigen::Vector2d centre = map.cellCentre(10, 10);
  const auto above = camera.worldToStream({centre.x(), centre.y(), 0.3});
  ASSERT_TRUE(above);
  const auto pixel = camera.pixelIndexAt(*above);
  ASSERT_TRUE(pixel);
  live.data()[*pixel] = 0;
  const CameraFrame with_floor{&floor, live.view(), background.view(), 20};
  const CameraFrame with_column{&column, live.view(), background.view(), 20};
  EXPECT_EQ(fuseReference(map, std::span(&with_floor, 1)).at(10, 10), CellState::kFree);
  EXPECT_EQ(fuseReference(map, std::span(&with_column, 1)).at(10, 10), CellState::kOccupied);
}

TEST(ReferenceFusion, RefusesImagesOfAnotherSize) {
  const MapGeometry map = smallMap();
  const CarveTable table = buildCarveTable(downwardCamera(), map, 0.0);
  const Image small(50, 50);
  const CameraFrame frame{&table, small.view(), small.view(), 20};
  EXPECT_THROW(fuseReference(map, std::span(&frame, 1)), std::invalid_argument);
}

}  // namespace
}  // namespace occmap
