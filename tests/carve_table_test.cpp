// Carve tables: no holes, the paper's table inside ours, floor masks honoured, column carving
// monotone in its height.
#include "core/carve_table.h"

#include <algorithm>
#include <random>

#include <gtest/gtest.h>

#include "core/reference_fusion.h"
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

TEST(CarveTable, RefusesAMaskOfAnotherSize) {
  std::mt19937_64 rng(1);
  const auto [camera, map] = testing::randomRig(rng);
  const Image mask(camera.streamWidth() + 1, camera.streamHeight());
  EXPECT_THROW(buildCarveTable(camera, map, 0.0, mask.view()), std::invalid_argument);
  EXPECT_THROW(buildCarveTable(camera, map, -0.1), std::invalid_argument);
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

}  // namespace
}  // namespace occmap
