#include "tools/pictures.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace occmap::tools {

cv::Point floorPlanPoint(const MapGeometry& map, int pixels_per_cell, double x, double y) {
  const double column = (x - map.origin_x_m) / map.cell_size_m;
  const double row = (y - map.origin_y_m) / map.cell_size_m;
  return {static_cast<int>(std::lround(column * pixels_per_cell)),
          static_cast<int>(std::lround((map.height - row) * pixels_per_cell))};
}

cv::Mat floorPlan(const OccupancyMap& map, int pixels_per_cell) {
  const MapGeometry& g = map.geometry;
  cv::Mat cells(g.height, g.width, CV_8UC3);
  for (int row = 0; row < g.height; ++row) {
    // Map row 0 is the smallest y: it goes at the bottom of the picture.
    auto* out = cells.ptr<cv::Vec3b>(g.height - 1 - row);
    for (int column = 0; column < g.width; ++column) {
      switch (map.at(row, column)) {
        case CellState::kFree:
          out[column] = {245, 245, 245};
          break;
        case CellState::kOccupied:
          out[column] = {35, 35, 35};
          break;
        case CellState::kUnseen:
          out[column] = {170, 140, 120};
          break;
      }
    }
  }
  cv::Mat picture;
  cv::resize(cells, picture, cv::Size(), pixels_per_cell, pixels_per_cell, cv::INTER_NEAREST);
  drawScaleBar(picture, g, pixels_per_cell);
  return picture;
}

void drawScaleBar(cv::Mat& picture, const MapGeometry& map, int pixels_per_cell) {
  const double width_m = map.width * map.cell_size_m;
  // The largest of 10 cm, 1 m, 10 m ... that fits in a quarter of the picture.
  double bar_m = std::pow(10.0, std::floor(std::log10(width_m / 4.0)));
  if (2 * bar_m <= width_m / 4.0) bar_m *= 2;
  const int bar_px = static_cast<int>(std::lround(bar_m / map.cell_size_m * pixels_per_cell));
  const cv::Point start(10, picture.rows - 12);
  const cv::Point end(start.x + bar_px, start.y);
  for (const auto& [colour, thickness] :
       {std::pair{cv::Scalar(255, 255, 255), 5}, std::pair{cv::Scalar(0, 0, 200), 2}}) {
    cv::line(picture, start, end, colour, thickness);
  }
  char label[32];
  std::snprintf(label, sizeof label, bar_m >= 1 ? "%.0f m" : "%.0f cm",
                bar_m >= 1 ? bar_m : bar_m * 100);
  cv::putText(picture, label, {start.x, start.y - 8}, cv::FONT_HERSHEY_SIMPLEX, 0.45,
              cv::Scalar(255, 255, 255), 3, cv::LINE_AA);
  cv::putText(picture, label, {start.x, start.y - 8}, cv::FONT_HERSHEY_SIMPLEX, 0.45,
              cv::Scalar(0, 0, 200), 1, cv::LINE_AA);
}

cv::Scalar cameraColour(std::size_t k) {
  static const cv::Scalar colours[] = {{60, 80, 230},  {60, 180, 60},  {230, 120, 40},
                                       {30, 200, 230}, {200, 60, 200}, {200, 200, 40},
                                       {90, 90, 160},  {40, 140, 250}};
  return colours[k % std::size(colours)];
}

cv::Mat coverageCells(const MapGeometry& map, std::span<const std::uint32_t> seen_by,
                      std::size_t cameras) {
  cv::Mat cells(map.height, map.width, CV_8UC3);
  for (int row = 0; row < map.height; ++row) {
    auto* out = cells.ptr<cv::Vec3b>(map.height - 1 - row);  // +y up
    for (int column = 0; column < map.width; ++column) {
      const std::uint32_t mask = seen_by[static_cast<std::size_t>(map.index(row, column))];
      const int n = std::popcount(mask);
      if (n == 0) {
        out[column] = {40, 40, 40};
        continue;
      }
      cv::Scalar sum(0, 0, 0);
      for (std::size_t k = 0; k < cameras; ++k) {
        if (mask >> k & 1) sum += cameraColour(k);
      }
      const double brightness = 0.55 + 0.45 * std::min(1.0, (n - 1) / 3.0);
      for (int c = 0; c < 3; ++c) {
        out[column][c] = cv::saturate_cast<std::uint8_t>(sum[c] / n * brightness + 25 * (n - 1));
      }
    }
  }
  return cells;
}

cv::Mat snapshot(const std::vector<std::pair<std::string, Image>>& cameras,
                 const OccupancyMap& map) {
  constexpr int kTileHeight = 240;
  std::vector<cv::Mat> tiles;
  int tile_width = 0;
  for (const auto& [name, image] : cameras) {
    const cv::Mat grey(image.height(), image.width(), CV_8UC1,
                       const_cast<std::uint8_t*>(image.data()));
    cv::Mat colour;
    cv::cvtColor(grey, colour, cv::COLOR_GRAY2BGR);
    const double scale = static_cast<double>(kTileHeight) / image.height();
    cv::resize(colour, colour, cv::Size(), scale, scale, cv::INTER_AREA);
    cv::putText(colour, name, {8, 22}, cv::FONT_HERSHEY_SIMPLEX, 0.6, {0, 0, 0}, 3, cv::LINE_AA);
    cv::putText(colour, name, {8, 22}, cv::FONT_HERSHEY_SIMPLEX, 0.6, {255, 255, 255}, 1,
                cv::LINE_AA);
    tile_width = std::max(tile_width, colour.cols);
    tiles.push_back(colour);
  }
  const int rows = static_cast<int>((tiles.size() + 1) / 2);
  cv::Mat grid(std::max(rows, 1) * kTileHeight, 2 * tile_width, CV_8UC3, cv::Scalar(0, 0, 0));
  for (std::size_t i = 0; i < tiles.size(); ++i) {
    const int x = static_cast<int>(i % 2) * tile_width;
    const int y = static_cast<int>(i / 2) * kTileHeight;
    tiles[i].copyTo(grid(cv::Rect(x, y, tiles[i].cols, tiles[i].rows)));
  }
  cv::Mat plan = floorPlan(map, 1);
  const double scale = static_cast<double>(grid.rows) / plan.rows;
  cv::resize(plan, plan, cv::Size(), scale, scale, cv::INTER_NEAREST);
  cv::Mat picture;
  cv::hconcat(grid, plan, picture);
  return picture;
}

}  // namespace occmap::tools
