// Carve tables: no holes, the paper's table inside ours, floor masks honoured, column carving
// monotone in its height.
#include "core/carve_table.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "core/opencv_camera.h"
#include "core/reference_fusion.h"
#include "core/tsai_camera.h"
#include "random_cameras.h"

namespace occmap {
namespace {

bool contains(std::span<const std::uint32_t> pixels, int pixel) {
  return std::binary_search(pixels.begin(), pixels.end(), static_cast<std::uint32_t>(pixel));
}

std::optional<int> centrePixel(const Camera& camera, const MapGeometry& map, int row, int column) {
  const Eigen::Vector2d c = map.cellCentre(row, column);
  const auto stream = camera.worldToStream({c.x(), c.y(), 0.0});
  if (!stream) return std::nullopt;
  return camera.pixelIndexAt(*stream);
}

Image randomMask(std::mt19937_64& rng, int width, int height) {
  // A floor mask with a rectangular hole (furniture) in it.
  Image mask(width, height, 255);
  std::uniform_int_distribution<int> u(0, width - 1), v(0, height - 1);
  const int u0 = u(rng), u1 = u(rng), v0 = v(rng), v1 = v(rng);
  for (int y = std::min(v0, v1); y <= std::max(v0, v1); ++y) {
    for (int x = std::min(u0, u1); x <= std::max(u0, u1); ++x) mask.at(x, y) = 0;
  }
  return mask;
}

TEST(CarveTable, FloorTableHasNoHolesAndHoldsThePapersTable) {
  std::mt19937_64 rng(20261122);
  int cameras_with_cells = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const auto [camera, map] = testing::randomRig(rng);
    const bool masked = trial % 2 == 1;
    const Image mask =
        masked ? randomMask(rng, camera.streamWidth(), camera.streamHeight()) : Image();
    const ImageView mask_view = masked ? mask.view() : ImageView{};
    auto floor = [&](int pixel) {
      return !masked || mask.at(pixel % camera.streamWidth(), pixel / camera.streamWidth()) != 0;
    };
    const CarveTable table = buildCarveTable(camera, map, 0.0, mask_view);
    ASSERT_EQ(table.rule(), CarveRule::kAnyPixel);
    std::size_t expected_entries = 0;
    std::vector<std::vector<int>> expected(map.cellCount());
    // No holes: every cell whose centre the camera sees in a floor pixel is decided by that pixel.
    for (int row = 0; row < map.height; ++row) {
      for (int column = 0; column < map.width; ++column) {
        const auto pixel = centrePixel(camera, map, row, column);
        const std::size_t cell = static_cast<std::size_t>(map.index(row, column));
        if (pixel && floor(*pixel)) {
          ASSERT_TRUE(table.sees(cell)) << "trial " << trial << " cell " << row << "," << column;
          ASSERT_TRUE(contains(table.pixelsOf(cell), *pixel)) << "trial " << trial;
          expected[cell].push_back(*pixel);
        }
      }
    }
    // The paper's table: every floor pixel's centre ray decides the cell where it meets the floor.
    for (int v = 0; v < camera.streamHeight(); ++v) {
      for (int u = 0; u < camera.streamWidth(); ++u) {
        const int pixel = v * camera.streamWidth() + u;
        if (!floor(pixel)) continue;
        const auto point = camera.streamToPlane({u, v}, 0.0);
        if (!point) continue;
        const auto cell = map.cellAt(point->x(), point->y());
        if (!cell) continue;
        ASSERT_TRUE(contains(table.pixelsOf(static_cast<std::size_t>(*cell)), pixel))
            << "trial " << trial << " pixel " << u << "," << v;
        expected[static_cast<std::size_t>(*cell)].push_back(pixel);
      }
    }
    // ... and nothing else.
    for (auto& pixels : expected) {
      std::sort(pixels.begin(), pixels.end());
      expected_entries +=
          static_cast<std::size_t>(std::unique(pixels.begin(), pixels.end()) - pixels.begin());
    }
    EXPECT_EQ(table.entries(), expected_entries) << "trial " << trial;
    if (table.cellsInView() > 0) ++cameras_with_cells;
  }
  // The property means little unless most random cameras actually see part of their map.
  EXPECT_GT(cameras_with_cells, 40);
}

TEST(CarveTable, ColumnTableDecidesEverySeenCellByItsWholeColumn) {
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 40; ++trial) {
    const auto [camera, map] = testing::randomRig(rng);
    const Image mask = randomMask(rng, camera.streamWidth(), camera.streamHeight());
    const CarveTable table = buildCarveTable(camera, map, 0.3, mask.view());
    ASSERT_EQ(table.rule(), CarveRule::kEveryPixel);
    for (int row = 0; row < map.height; ++row) {
      for (int column = 0; column < map.width; ++column) {
        const std::size_t cell = static_cast<std::size_t>(map.index(row, column));
        const auto pixel = centrePixel(camera, map, row, column);
        const bool seen =
            pixel && mask.at(*pixel % camera.streamWidth(), *pixel / camera.streamWidth()) != 0;
        ASSERT_EQ(table.sees(cell), seen) << "trial " << trial;
        if (!seen) continue;
        ASSERT_TRUE(contains(table.pixelsOf(cell), *pixel));
        // Every point of the column images into one of the cell's pixels (or outside the stream).
        const Eigen::Vector2d c = map.cellCentre(row, column);
        for (double z = 0.0; z <= 0.3; z += 0.0007) {
          const auto stream = camera.worldToStream({c.x(), c.y(), z});
          if (!stream) break;
          const auto p = camera.pixelIndexAt(*stream);
          if (p) {
            ASSERT_TRUE(contains(table.pixelsOf(cell), *p))
                << "trial " << trial << " z " << z << " cell " << row << "," << column;
          }
        }
      }
    }
  }
}

TEST(CarveTable, ColumnCarvingIsMonotoneInHeight) {
  std::mt19937_64 rng(99);
  const double heights[] = {0.0, 0.01, 0.045, 0.17, 0.3, 0.95};
  for (int trial = 0; trial < 25; ++trial) {
    const auto [camera, map] = testing::randomRig(rng);
    std::vector<CarveTable> tables;
    for (double h : heights) tables.push_back(buildCarveTable(camera, map, h));
    // A lower column's pixels are a subset of a higher one's, and they see the same cells.
    for (std::size_t k = 2; k < tables.size(); ++k) {
      for (std::size_t cell = 0; cell < map.cellCount(); ++cell) {
        ASSERT_EQ(tables[k].sees(cell), tables[1].sees(cell));
        const auto low = tables[k - 1].pixelsOf(cell);
        const auto high = tables[k].pixelsOf(cell);
        ASSERT_TRUE(std::includes(high.begin(), high.end(), low.begin(), low.end()))
            << "trial " << trial << " height " << heights[k];
      }
    }
    // So, on any images, what a higher column clears a lower one clears too, and the floor-point
    // carving (height 0) clears at least as much as any column.
    std::uniform_int_distribution<int> grey(0, 255);
    Image background(camera.streamWidth(), camera.streamHeight());
    Image live(camera.streamWidth(), camera.streamHeight());
    for (int v = 0; v < live.height(); ++v) {
      for (int u = 0; u < live.width(); ++u) {
        background.at(u, v) = static_cast<std::uint8_t>(grey(rng));
        // About 10 % changed pixels.
        live.at(u, v) = grey(rng) < 26 ? static_cast<std::uint8_t>(255 - background.at(u, v))
                                       : background.at(u, v);
      }
    }
    std::vector<OccupancyMap> maps;
    for (const CarveTable& table : tables) {
      const CameraFrame frame{&table, live.view(), background.view(), 20};
      maps.push_back(fuseReference(map, std::span(&frame, 1)));
    }
    for (std::size_t k = 1; k < maps.size(); ++k) {
      for (std::size_t cell = 0; cell < map.cellCount(); ++cell) {
        if (maps[k].cells[cell] == CellState::kFree) {
          ASSERT_EQ(maps[k - 1].cells[cell], CellState::kFree)
              << "trial " << trial << " height " << heights[k] << " cleared what " << heights[k - 1]
              << " did not";
        }
      }
    }
  }
}

// The fast build's tables against the straightforward one's, cell by cell.
void expectSameTable(const CarveTable& fast, const CarveTable& reference, const std::string& what) {
  ASSERT_EQ(fast.rule(), reference.rule()) << what;
  ASSERT_EQ(fast.imageWidth(), reference.imageWidth()) << what;
  ASSERT_EQ(fast.imageHeight(), reference.imageHeight()) << what;
  ASSERT_EQ(fast.entries(), reference.entries()) << what;
  for (std::size_t cell = 0; cell < reference.map().cellCount(); ++cell) {
    const auto a = fast.pixelsOf(cell);
    const auto b = reference.pixelsOf(cell);
    ASSERT_TRUE(std::equal(a.begin(), a.end(), b.begin(), b.end())) << what << " cell " << cell;
  }
}

// A camera straight above the map's middle, without distortion, whose cells fall on pixel edges
// and corners: every decision of the fast build is a near one there, so it must fall back to
// exact projections, cell by cell.
testing::RandomRig cameraOnTheGrid() {
  TsaiParameters p;
  p.width = 64;
  p.height = 48;
  p.ncx = p.nfx = p.width;
  p.dx = p.dy = p.dpx = p.dpy = 0.01;
  p.focal = 1.0;
  p.kappa1 = 0.0;
  p.cx = 31.5;  // the principal point on a pixel corner
  p.cy = 23.5;
  // 2 m up looking down: a pixel is 20 mm of floor, pixel edges lie every 20 mm from x = y = 0,
  // and every other cell centre (10 mm apart) lies on one.
  p.setPose(poseLookingAt({0.0, 0.0, 2000.0}, {0.0, 1e-9, 0.0}));
  MapGeometry map;
  map.cell_size_m = 0.01;
  map.width = 120;
  map.height = 90;
  map.origin_x_m = -0.605;
  map.origin_y_m = -0.455;
  return {Camera(std::make_shared<TsaiCamera>(p), LengthUnit::kMillimetre, p.width, p.height), map};
}

// The same camera through OpenCV's model, which the fast build projects the exact way only.
Camera asOpenCvCamera(const Camera& camera, double k1) {
  const auto& tsai = dynamic_cast<const TsaiCamera&>(camera.model());
  const TsaiParameters& t = tsai.parameters();
  OpenCvParameters p;
  p.width = t.width;
  p.height = t.height;
  p.fx = t.focal * t.sx / t.dpx;
  p.fy = t.focal / t.dpy;
  p.cx = t.cx;
  p.cy = t.cy;
  p.distortion = {k1, 0, 0, 0, 0};
  const Eigen::AngleAxisd rotation(tsai.pose().rotation);
  p.rvec = rotation.angle() * rotation.axis();
  p.tvec = tsai.pose().translation;
  return Camera(std::make_shared<OpenCvCamera>(p), LengthUnit::kMillimetre, camera.streamWidth(),
                camera.streamHeight(), camera.region());
}

TEST(CarveTable, FastBuildGivesTheReferenceTable) {
  std::mt19937_64 rng(5150);
  const double heights[] = {0.0, 0.01, 0.045, 0.17, 0.3, 0.95};
  for (int trial = 0; trial < 120; ++trial) {
    const auto [camera, map] = testing::randomRig(rng);
    const Image mask = randomMask(rng, camera.streamWidth(), camera.streamHeight());
    const ImageView mask_view = trial % 2 == 1 ? mask.view() : ImageView{};
    for (const double h : heights) {
      expectSameTable(buildCarveTable(camera, map, h, mask_view),
                      buildCarveTableReference(camera, map, h, mask_view),
                      "trial " + std::to_string(trial) + " height " + std::to_string(h));
    }
  }
  const auto [camera, map] = cameraOnTheGrid();
  for (const double h : heights) {
    expectSameTable(buildCarveTable(camera, map, h), buildCarveTableReference(camera, map, h),
                    "camera on the grid, height " + std::to_string(h));
  }
  for (int trial = 0; trial < 10; ++trial) {
    const auto [tsai, opencv_map] = testing::randomRig(rng);
    const Camera opencv =
        asOpenCvCamera(tsai, std::uniform_real_distribution<double>(-0.1, 0.1)(rng));
    for (const double h : {0.0, 0.3}) {
      expectSameTable(buildCarveTable(opencv, opencv_map, h),
                      buildCarveTableReference(opencv, opencv_map, h),
                      "OpenCV trial " + std::to_string(trial) + " height " + std::to_string(h));
    }
  }
}

// Random cameras almost never put a decision within rounding of its pixel edge, so here the
// reference is made to: a map of one cell slides right until the reference's table for it
// changes, and is bisected down to two neighbouring doubles across that change. On either side
// the reference decides a pixel edge or corner (the centre's pixel, a knot's, a piece of column
// passing a corner) within rounding, where a projection a hair off would go the other way if
// the fast build did not fall back to exact ones there.
TEST(CarveTable, FastBuildAgreesWhereTheReferenceDecidesWithinRounding) {
  std::mt19937_64 rng(1618);
  int bisected = 0;
  for (int trial = 0; trial < 160; ++trial) {
    const testing::RandomRig rig = testing::randomRig(rng);
    const Camera& camera = rig.camera;
    const MapGeometry& map = rig.map;
    const double h = trial % 2 == 0 ? 0.0 : 0.3;
    std::uniform_int_distribution<int> row(0, map.height - 1), column(0, map.width - 1);
    MapGeometry one = map;
    one.width = one.height = 1;
    bool found = false;
    for (int attempt = 0; attempt < 200 && !found; ++attempt) {
      one.origin_x_m = map.origin_x_m + column(rng) * map.cell_size_m;
      one.origin_y_m = map.origin_y_m + row(rng) * map.cell_size_m;
      found = centrePixel(camera, one, 0, 0).has_value();
    }
    if (!found) continue;
    // What the reference decides with the cell's corner at x0. In floor mode only the centre's
    // pixel is the fast build's own (the paper's part is the same code in both).
    auto decided = [&](double x0) {
      MapGeometry at = one;
      at.origin_x_m = x0;
      if (h == 0.0) {
        return std::vector<std::uint32_t>{
            static_cast<std::uint32_t>(centrePixel(camera, at, 0, 0).value_or(-1))};
      }
      const CarveTable table = buildCarveTableReference(camera, at, h);
      return std::vector<std::uint32_t>(table.pixelsOf(0).begin(), table.pixelsOf(0).end());
    };
    double low = one.origin_x_m;
    double high = low + map.cell_size_m;
    const std::vector<std::uint32_t> start = decided(low);
    if (decided(high) == start) continue;
    while (std::nextafter(low, high) < high) {
      const double middle = low + (high - low) / 2;
      if (!(middle > low && middle < high)) break;
      (decided(middle) == start ? low : high) = middle;
    }
    for (const double x0 : {low, high}) {
      MapGeometry at = one;
      at.origin_x_m = x0;
      expectSameTable(buildCarveTable(camera, at, h), buildCarveTableReference(camera, at, h),
                      "trial " + std::to_string(trial) + " height " + std::to_string(h));
    }
    ++bisected;
  }
  EXPECT_GT(bisected, 120);
}

TEST(FastProjector, StaysWithinItsBoundOfWorldToStream) {
  std::mt19937_64 rng(2718);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::size_t fast_points = 0, points = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const auto [camera, map] = testing::randomRig(rng);
    FastProjector projector(camera);
    const double width = map.width * map.cell_size_m, height = map.height * map.cell_size_m;
    for (int k = 0; k < 3000; ++k) {
      // Points over the map and far round it, up to 3 m: in and out of view, behind the camera.
      const Eigen::Vector3d world(map.origin_x_m + (3 * unit(rng) - 1) * width,
                                  map.origin_y_m + (3 * unit(rng) - 1) * height,
                                  k % 2 == 0 ? 0.0 : 3 * unit(rng));
      const std::optional<Eigen::Vector2d> exact = camera.worldToStream(world);
      const std::optional<FastProjector::Point> fast = projector.project(world);
      ++points;
      ASSERT_EQ(fast.has_value(), exact.has_value()) << "trial " << trial << " point " << k;
      if (!exact) continue;
      ASSERT_LE(fast->error_px, kFastProjectionTolerancePx);
      ASSERT_LE((fast->stream - *exact).norm(), fast->error_px)
          << "trial " << trial << " point " << k << ": off by " << (fast->stream - *exact).norm()
          << " px, bound " << fast->error_px;
      if (fast->error_px > 0) ++fast_points;
    }
    // Whole columns at once, as the table build projects its knots.
    for (int k = 0; k < 300; ++k) {
      const double x = map.origin_x_m + (3 * unit(rng) - 1) * width;
      const double y = map.origin_y_m + (3 * unit(rng) - 1) * height;
      std::vector<double> heights;
      for (double z = 0.01 * (1 + k % 10); z < 0.4; z += 0.01 * (1 + k % 10)) heights.push_back(z);
      std::vector<std::optional<FastProjector::Point>> column(heights.size());
      projector.projectColumn(x, y, heights, column);
      for (std::size_t i = 0; i < heights.size(); ++i) {
        const std::optional<Eigen::Vector2d> exact = camera.worldToStream({x, y, heights[i]});
        ASSERT_EQ(column[i].has_value(), exact.has_value()) << "trial " << trial << " column " << k;
        if (!exact) continue;
        ASSERT_LE(column[i]->error_px, kFastProjectionTolerancePx);
        ASSERT_LE((column[i]->stream - *exact).norm(), column[i]->error_px)
            << "trial " << trial << " column " << k << " height " << heights[i];
      }
    }
  }
  // Most points must take the fast path, or the build is no faster and this test proves little.
  EXPECT_GT(fast_points, points / 3);
}

TEST(CarveTable, RefusesAMaskOfAnotherSize) {
  std::mt19937_64 rng(1);
  const auto [camera, map] = testing::randomRig(rng);
  const Image mask(camera.streamWidth() + 1, camera.streamHeight());
  EXPECT_THROW(buildCarveTable(camera, map, 0.0, mask.view()), std::invalid_argument);
  EXPECT_THROW(buildCarveTable(camera, map, -0.1), std::invalid_argument);
  EXPECT_THROW(buildCarveTableReference(camera, map, 0.0, mask.view()), std::invalid_argument);
}

TEST(SegmentWalk, VisitsEveryPixelTheSegmentCrossesAndNoOther) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> coordinate(-3, 23);
  for (int trial = 0; trial < 2000; ++trial) {
    const Eigen::Vector2d a(coordinate(rng), coordinate(rng));
    const Eigen::Vector2d b =
        trial % 3 == 0 ? a : Eigen::Vector2d(coordinate(rng), coordinate(rng));
    std::vector<std::uint32_t> walked;
    forEachPixelOnSegment(a, b, 20, 20, walked);
    std::vector<std::uint32_t> sampled;
    for (int k = 0; k <= 20000; ++k) {
      const Eigen::Vector2d p = a + (b - a) * (k / 20000.0);
      const double u = std::floor(p.x() + 0.5), v = std::floor(p.y() + 0.5);
      if (u >= 0 && v >= 0 && u < 20 && v < 20)
        sampled.push_back(static_cast<std::uint32_t>(v * 20 + u));
    }
    std::sort(walked.begin(), walked.end());
    std::sort(sampled.begin(), sampled.end());
    sampled.erase(std::unique(sampled.begin(), sampled.end()), sampled.end());
    ASSERT_TRUE(std::adjacent_find(walked.begin(), walked.end()) == walked.end())
        << "a pixel visited twice";
    // Dense samples can only miss a pixel the segment clips at a corner, never add one.
    ASSERT_TRUE(std::includes(walked.begin(), walked.end(), sampled.begin(), sampled.end()));
    ASSERT_LE(walked.size(), sampled.size() + 2);
  }
}

// A column that passes close by a low camera images out towards infinity (fuzzing found one):
// the walk must give the pixels of the part in view, in order, without stepping through the
// 1e9 pixel boundaries beyond it.
TEST(SegmentWalk, ASegmentReachingFarOffTheImageGivesThePixelsOfItsPartInView) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> coordinate(0, 19);
  std::uniform_real_distribution<double> angle(0, 2 * 3.141592653589793);
  for (int trial = 0; trial < 500; ++trial) {
    const Eigen::Vector2d centre(coordinate(rng), coordinate(rng));
    const double theta = angle(rng);
    const Eigen::Vector2d direction(std::cos(theta), std::sin(theta));
    const double far = trial % 2 == 0 ? 1e8 : 1e10;
    std::vector<std::uint32_t> near_walk, far_walk;
    // One end in view, the other far off.
    forEachPixelOnSegment(centre, centre + far * direction, 20, 20, far_walk);
    forEachPixelOnSegment(centre, centre + 100 * direction, 20, 20, near_walk);
    ASSERT_EQ(far_walk, near_walk) << "trial " << trial;
    ASSERT_FALSE(far_walk.empty());
    // Both ends far off, on either side of the image.
    far_walk.clear();
    near_walk.clear();
    forEachPixelOnSegment(centre - far * direction, centre + far * direction, 20, 20, far_walk);
    forEachPixelOnSegment(centre - 100 * direction, centre + 100 * direction, 20, 20, near_walk);
    ASSERT_EQ(far_walk, near_walk) << "trial " << trial;
    // Far off and passing the image by.
    far_walk.clear();
    const Eigen::Vector2d beside = centre + Eigen::Vector2d(-direction.y(), direction.x()) * 60;
    forEachPixelOnSegment(beside - far * direction, beside + far * direction, 20, 20, far_walk);
    ASSERT_TRUE(far_walk.empty()) << "trial " << trial;
  }
}

}  // namespace
}  // namespace occmap
