#include "core/carve_table.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace occmap {

CarveTable::CarveTable(CarveRule rule, const MapGeometry& map, int image_width, int image_height,
                       std::vector<std::uint32_t> cell_offsets,
                       std::vector<std::uint32_t> cell_pixels)
    : rule_(rule),
      map_(map),
      image_width_(image_width),
      image_height_(image_height),
      offsets_(std::move(cell_offsets)),
      pixels_(std::move(cell_pixels)) {}

std::size_t CarveTable::cellsInView() const {
  std::size_t count = 0;
  for (std::size_t cell = 0; cell + 1 < offsets_.size(); ++cell) count += sees(cell) ? 1 : 0;
  return count;
}

void forEachPixelOnSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b, int width,
                           int height, std::vector<std::uint32_t>& out) {
  // Amanatides & Woo's grid walk. Shifted by 0.5, pixel i spans [i, i + 1).
  const double ax = a.x() + 0.5, ay = a.y() + 0.5;
  const double bx = b.x() + 0.5, by = b.y() + 0.5;
  long x = static_cast<long>(std::floor(ax));
  long y = static_cast<long>(std::floor(ay));
  const long end_x = static_cast<long>(std::floor(bx));
  const long end_y = static_cast<long>(std::floor(by));
  const double dx = bx - ax;
  const double dy = by - ay;
  const long step_x = dx > 0 ? 1 : (dx < 0 ? -1 : 0);
  const long step_y = dy > 0 ? 1 : (dy < 0 ? -1 : 0);
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  double next_x = step_x > 0   ? (static_cast<double>(x) + 1 - ax) / dx
                  : step_x < 0 ? (static_cast<double>(x) - ax) / dx
                               : kInfinity;
  double next_y = step_y > 0   ? (static_cast<double>(y) + 1 - ay) / dy
                  : step_y < 0 ? (static_cast<double>(y) - ay) / dy
                               : kInfinity;
  const double delta_x = step_x != 0 ? 1.0 / std::abs(dx) : kInfinity;
  const double delta_y = step_y != 0 ? 1.0 / std::abs(dy) : kInfinity;
  long steps_x = std::abs(end_x - x);
  long steps_y = std::abs(end_y - y);
  auto visit = [&] {
    if (x >= 0 && y >= 0 && x < width && y < height) {
      out.push_back(static_cast<std::uint32_t>(y * width + x));
    }
  };
  visit();
  // Exactly one step per pixel boundary crossed; the counts keep rounding from overshooting the
  // end.
  while (steps_x > 0 || steps_y > 0) {
    if (steps_y == 0 || (steps_x > 0 && next_x < next_y)) {
      x += step_x;
      next_x += delta_x;
      --steps_x;
    } else {
      y += step_y;
      next_y += delta_y;
      --steps_y;
    }
    visit();
  }
}

namespace {

bool isFloorPixel(ImageView mask, int index, int width) {
  return mask.empty() || mask.at(index % width, index / width) != 0;
}

// The stream pixel containing the projection of the cell's centre, if the camera sees the cell
// there.
std::optional<int> centrePixel(const Camera& camera, const MapGeometry& map, int row, int column,
                               ImageView mask) {
  const Eigen::Vector2d centre = map.cellCentre(row, column);
  const std::optional<Eigen::Vector2d> stream =
      camera.worldToStream(Eigen::Vector3d(centre.x(), centre.y(), 0.0));
  if (!stream) return std::nullopt;
  const std::optional<int> pixel = camera.pixelIndexAt(*stream);
  if (!pixel || !isFloorPixel(mask, *pixel, camera.streamWidth())) return std::nullopt;
  return pixel;
}

CarveTable fromEdges(CarveRule rule, const Camera& camera, const MapGeometry& map,
                     std::vector<std::uint64_t>& edges) {
  // Edges are (cell << 32 | pixel): sorted, they are the table row by row with pixels ascending.
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  std::vector<std::uint32_t> offsets(map.cellCount() + 1, 0);
  std::vector<std::uint32_t> pixels;
  pixels.reserve(edges.size());
  for (const std::uint64_t edge : edges) {
    ++offsets[(edge >> 32) + 1];
    pixels.push_back(static_cast<std::uint32_t>(edge & 0xffffffffu));
  }
  for (std::size_t i = 1; i < offsets.size(); ++i) offsets[i] += offsets[i - 1];
  return CarveTable(rule, map, camera.streamWidth(), camera.streamHeight(), std::move(offsets),
                    std::move(pixels));
}

std::uint64_t edge(int cell, int pixel) {
  return (static_cast<std::uint64_t>(cell) << 32) | static_cast<std::uint32_t>(pixel);
}

CarveTable buildFloorTable(const Camera& camera, const MapGeometry& map, ImageView mask) {
  std::vector<std::uint64_t> edges;
  // The paper's table: each floor pixel's centre to the cell its ray meets on the floor.
  const int width = camera.streamWidth();
  for (int v = 0; v < camera.streamHeight(); ++v) {
    for (int u = 0; u < width; ++u) {
      if (!mask.empty() && mask.at(u, v) == 0) continue;
      const std::optional<Eigen::Vector3d> floor = camera.streamToPlane(Eigen::Vector2d(u, v), 0.0);
      if (!floor) continue;
      const std::optional<int> cell = map.cellAt(floor->x(), floor->y());
      if (cell) edges.push_back(edge(*cell, v * width + u));
    }
  }
  // No holes: each cell whose centre projects into a floor pixel is decided by that pixel too.
  for (int row = 0; row < map.height; ++row) {
    for (int column = 0; column < map.width; ++column) {
      const std::optional<int> pixel = centrePixel(camera, map, row, column, mask);
      if (pixel) edges.push_back(edge(map.index(row, column), *pixel));
    }
  }
  return fromEdges(CarveRule::kAnyPixel, camera, map, edges);
}

// The pixels of the image of the column over `centre`, from the floor up to steps * kColumnStepM.
// The column's image is a curve (a straight line bent a little by the lens); it is followed through
// knots projected exactly every knot_steps * kColumnStepM, where knot_steps depends only on the
// cell (about a pixel between knots, 1 to 10 cm, so that chord and curve stay well within a
// pixel of each other), and the last piece ends on its chord. A lower
// column's path is therefore always a prefix of a higher one's, which keeps carving monotone.
void walkColumn(const Camera& camera, const Eigen::Vector2d& centre, int steps,
                std::vector<std::uint32_t>& out) {
  const int width = camera.streamWidth();
  const int height = camera.streamHeight();
  auto project = [&](double z) { return camera.worldToStream({centre.x(), centre.y(), z}); };
  const std::optional<Eigen::Vector2d> bottom = project(0.0);
  forEachPixelOnSegment(*bottom, *bottom, width, height, out);
  if (steps == 0) return;
  // The column's image length near the floor sets this cell's knot spacing (about one pixel).
  const std::optional<Eigen::Vector2d> probe = project(0.1);
  int knot_steps = 1;
  if (probe) {
    const double pixels_per_step = (*probe - *bottom).norm() / 0.1 * kColumnStepM;
    knot_steps = std::clamp(static_cast<int>(1.0 / std::max(pixels_per_step, 1e-9)), 1, 10);
  }
  Eigen::Vector2d previous = *bottom;
  for (int knot = knot_steps;; knot += knot_steps) {
    const std::optional<Eigen::Vector2d> next = project(knot * kColumnStepM);
    // Where the column leaves the lens model's valid part, the rest of it cannot be checked.
    if (!next) return;
    if (knot >= steps) {
      // The top lies on this chord: walk to it and stop.
      const double fraction = static_cast<double>(steps - (knot - knot_steps)) / knot_steps;
      forEachPixelOnSegment(previous, previous + (*next - previous) * fraction, width, height, out);
      return;
    }
    forEachPixelOnSegment(previous, *next, width, height, out);
    previous = *next;
  }
}

CarveTable buildColumnTable(const Camera& camera, const MapGeometry& map, double column_height_m,
                            ImageView mask) {
  const int steps = static_cast<int>(std::ceil(column_height_m / kColumnStepM - 1e-9));
  // Cells come in order, so the table is written row by row without a global sort.
  std::vector<std::uint32_t> offsets(map.cellCount() + 1, 0);
  std::vector<std::uint32_t> pixels;
  std::vector<std::uint32_t> column_pixels;
  for (int row = 0; row < map.height; ++row) {
    for (int column = 0; column < map.width; ++column) {
      const auto cell = static_cast<std::size_t>(map.index(row, column));
      offsets[cell + 1] = offsets[cell];
      if (!centrePixel(camera, map, row, column, mask)) continue;
      const Eigen::Vector2d centre = map.cellCentre(row, column);
      column_pixels.clear();
      walkColumn(camera, centre, steps, column_pixels);
      std::sort(column_pixels.begin(), column_pixels.end());
      const auto last = std::unique(column_pixels.begin(), column_pixels.end());
      pixels.insert(pixels.end(), column_pixels.begin(), last);
      offsets[cell + 1] = static_cast<std::uint32_t>(pixels.size());
    }
  }
  return CarveTable(CarveRule::kEveryPixel, map, camera.streamWidth(), camera.streamHeight(),
                    std::move(offsets), std::move(pixels));
}

}  // namespace

CarveTable buildCarveTable(const Camera& camera, const MapGeometry& map, double column_height_m,
                           ImageView floor_mask) {
  if (!floor_mask.empty() &&
      (floor_mask.width != camera.streamWidth() || floor_mask.height != camera.streamHeight())) {
    throw std::invalid_argument("floor mask size differs from the stream's");
  }
  if (!(column_height_m >= 0.0)) throw std::invalid_argument("column height must be >= 0");
  if (column_height_m == 0.0) return buildFloorTable(camera, map, floor_mask);
  return buildColumnTable(camera, map, column_height_m, floor_mask);
}

}  // namespace occmap
