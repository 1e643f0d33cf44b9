#include "core/carve_table.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/tsai_camera.h"

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
  double ax = a.x() + 0.5, ay = a.y() + 0.5;
  double bx = b.x() + 0.5, by = b.y() + 0.5;
  // A column that passes close by a low camera images out towards infinity, and the walk takes
  // one step per pixel boundary, off the image too: 1e9 steps and more (fuzzing found a valid
  // calibration whose tables took over 10 minutes). Clip first (Liang & Barsky) to the stream
  // widened by a pixel: the clipped ends then lie in pixels outside the image, so no pixel in
  // bounds is gained or lost, and the walk takes at most about width + height steps.
  const double low_x = -1.0, high_x = width + 1.0;
  const double low_y = -1.0, high_y = height + 1.0;
  auto inside = [&](double x, double y) {
    return x >= low_x && x <= high_x && y >= low_y && y <= high_y;
  };
  if (!inside(ax, ay) || !inside(bx, by)) {
    const double dx = bx - ax, dy = by - ay;
    double t_enter = 0.0, t_leave = 1.0;
    // Each side: p * t <= q keeps the point on the inner side.
    const std::array<std::array<double, 2>, 4> sides = {
        {{-dx, ax - low_x}, {dx, high_x - ax}, {-dy, ay - low_y}, {dy, high_y - ay}}};
    for (const auto& [p, q] : sides) {
      if (p == 0.0) {
        if (q < 0.0) return;  // parallel to this side and beyond it
        continue;
      }
      const double t = q / p;
      if (p < 0.0) {
        t_enter = std::max(t_enter, t);
      } else {
        t_leave = std::min(t_leave, t);
      }
    }
    if (!(t_enter <= t_leave)) return;  // misses the widened stream (or not finite)
    const double start_x = ax + t_enter * dx, start_y = ay + t_enter * dy;
    bx = ax + t_leave * dx;
    by = ay + t_leave * dy;
    ax = start_x;
    ay = start_y;
  }
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

constexpr double kUnitRoundoff = std::numeric_limits<double>::epsilon() / 2;

// Where the checked walk works at all: far beyond any image, with pixel coordinates still held to
// 1e-7 (their last place), well within kDecisionMarginPx.
constexpr double kWalkRange = 1e9;

// std::floor without a call into libm (baseline x86-64 has no rounding instruction), for
// |x| < kWalkRange.
double floorInRange(double x) {
  const auto t = static_cast<double>(static_cast<std::int64_t>(x));
  return t > x ? t - 1.0 : t;
}

// A walk's end point, shifted by 0.5 (pixel i spans [i, i + 1)), and the pixel it falls in.
struct WalkPoint {
  double x = 0;
  double y = 0;
  long column = 0;
  long row = 0;
};

// False where `stream` lies within kDecisionMarginPx of a pixel edge, where a point a little off
// could fall in the neighbouring pixel (the stream's bounds are pixel edges too), or out of range.
bool locate(const Eigen::Vector2d& stream, WalkPoint& point) {
  point.x = stream.x() + 0.5;
  point.y = stream.y() + 0.5;
  if (!(std::abs(point.x) < kWalkRange && std::abs(point.y) < kWalkRange)) return false;
  const double column = floorInRange(point.x);
  const double row = floorInRange(point.y);
  const double fraction_x = point.x - column;  // exact
  const double fraction_y = point.y - row;
  if (fraction_x < kDecisionMarginPx || fraction_x > 1.0 - kDecisionMarginPx ||
      fraction_y < kDecisionMarginPx || fraction_y > 1.0 - kDecisionMarginPx) {
    return false;
  }
  point.column = static_cast<long>(column);
  point.row = static_cast<long>(row);
  return true;
}

// The pixels forEachPixelOnSegment visits from a to b, but a's own (the walk's last, or the
// centre's), or false (`out` then partly written) where they could differ for end points moved by
// less than kDecisionMarginPx: end points must have been located, and a pixel corner near the
// segment, where the walk decides which of its two neighbours comes next, refuses it. Away from
// those, every decision has a margin far beyond rounding, so any two segments within the margin
// of each other, this one and the reference's, cross the same pixels. Each step goes by the side
// of the corner ahead (the sign of a cross product, no divisions), which is the walk's own
// decision wherever the margin holds.
bool walkSegmentChecked(const WalkPoint& a, const WalkPoint& b, int width, int height,
                        std::vector<std::uint32_t>& out) {
  long x = a.column;
  long y = a.row;
  const double dx = b.x - a.x;
  const double dy = b.y - a.y;
  const long step_x = dx > 0 ? 1 : -1;  // unused when the segment stays in its column
  const long step_y = dy > 0 ? 1 : -1;
  long steps_x = std::abs(b.column - x);
  long steps_y = std::abs(b.row - y);
  // The reference's crossing parameters gather rounding with every step (about 1e-16 each), and
  // a corner kDecisionMarginPx from a segment n pixels long differs in them by at least
  // 2 kDecisionMarginPx / n: beyond a few thousand steps that margin would no longer be safe.
  if (steps_x + steps_y > 4096) return false;
  auto visit = [&] {
    if (x >= 0 && y >= 0 && x < width && y < height) {
      out.push_back(static_cast<std::uint32_t>(y * width + x));
    }
  };
  // The squared margin times the squared length, against which a corner's cross product is held.
  const double corner_limit = kDecisionMarginPx * kDecisionMarginPx * (dx * dx + dy * dy);
  // The column boundary comes first when the corner lies on this side of the segment.
  const bool same_signs = (dx > 0) == (dy > 0);
  while (steps_x > 0 && steps_y > 0) {
    const double corner_x = static_cast<double>(x + (step_x > 0 ? 1 : 0));
    const double corner_y = static_cast<double>(y + (step_y > 0 ? 1 : 0));
    const double cross = dx * (corner_y - a.y) - dy * (corner_x - a.x);
    if (cross * cross < corner_limit) return false;
    if ((cross > 0) == same_signs) {
      x += step_x;
      --steps_x;
    } else {
      y += step_y;
      --steps_y;
    }
    visit();
  }
  for (; steps_x > 0; --steps_x) {
    x += step_x;
    visit();
  }
  for (; steps_y > 0; --steps_y) {
    y += step_y;
    visit();
  }
  return true;
}

}  // namespace

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

// The paper's table: each floor pixel's centre to the cell its ray meets on the floor.
void addPaperEdges(const Camera& camera, const MapGeometry& map, ImageView mask,
                   std::vector<std::uint64_t>& edges) {
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
}

CarveTable buildFloorTableReference(const Camera& camera, const MapGeometry& map, ImageView mask) {
  std::vector<std::uint64_t> edges;
  addPaperEdges(camera, map, mask, edges);
  // No holes: each cell whose centre projects into a floor pixel is decided by that pixel too.
  for (int row = 0; row < map.height; ++row) {
    for (int column = 0; column < map.width; ++column) {
      const std::optional<int> pixel = centrePixel(camera, map, row, column, mask);
      if (pixel) edges.push_back(edge(map.index(row, column), *pixel));
    }
  }
  return fromEdges(CarveRule::kAnyPixel, camera, map, edges);
}

// Knots every this many column steps, for a column whose image runs `length` stream pixels over
// its lowest 10 cm: about one pixel apart, 1 to 10 steps.
int knotStepsFor(double length) {
  const double pixels_per_step = length / 0.1 * kColumnStepM;
  return std::clamp(static_cast<int>(1.0 / std::max(pixels_per_step, 1e-9)), 1, 10);
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
  if (probe) knot_steps = knotStepsFor((*probe - *bottom).norm());
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

int columnSteps(double column_height_m) {
  return static_cast<int>(std::ceil(column_height_m / kColumnStepM - 1e-9));
}

void appendSorted(std::vector<std::uint32_t>& column_pixels, std::vector<std::uint32_t>& pixels) {
  std::sort(column_pixels.begin(), column_pixels.end());
  const auto last = std::unique(column_pixels.begin(), column_pixels.end());
  pixels.insert(pixels.end(), column_pixels.begin(), last);
}

// appendSorted for the twenty-odd pixels of a column in the order the walk found them: mostly
// rising or mostly falling (the column's image runs up or down the image), so, turned the right
// way round, an insertion sort has little to do.
void appendSortedColumn(std::vector<std::uint32_t>& column_pixels,
                        std::vector<std::uint32_t>& pixels) {
  std::uint32_t* const p = column_pixels.data();
  const std::size_t n = column_pixels.size();
  if (n > 1 && p[0] > p[n - 1]) std::reverse(p, p + n);
  for (std::size_t i = 1; i < n; ++i) {
    const std::uint32_t pixel = p[i];
    std::size_t at = i;
    for (; at > 0 && p[at - 1] > pixel; --at) p[at] = p[at - 1];
    p[at] = pixel;
  }
  // One push_back each rather than one insert: the same in a plain build, and under
  // ThreadSanitizer an insert is an intercepted memmove, which was a fifth of a table's build.
  const std::uint32_t* const end = std::unique(p, p + n);
  for (const std::uint32_t* q = p; q != end; ++q) pixels.push_back(*q);
}

CarveTable buildColumnTableReference(const Camera& camera, const MapGeometry& map,
                                     double column_height_m, ImageView mask) {
  const int steps = columnSteps(column_height_m);
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
      appendSorted(column_pixels, pixels);
      offsets[cell + 1] = static_cast<std::uint32_t>(pixels.size());
    }
  }
  return CarveTable(CarveRule::kEveryPixel, map, camera.streamWidth(), camera.streamHeight(),
                    std::move(offsets), std::move(pixels));
}

// What the fast path found for a cell: kUnsure where a decision lies within kDecisionMarginPx of
// its pixel edge or corner, and the cell must be built from exact projections instead.
enum class Decision { kUnseen, kSeen, kUnsure };

// centrePixel on a fast projection of the cell's centre (kept in `bottom`, located in `where`).
Decision fastCentrePixel(const FastProjector& projector, const Camera& camera, ImageView mask,
                         const Eigen::Vector2d& centre, std::optional<FastProjector::Point>& bottom,
                         WalkPoint& where, int& pixel) {
  bottom = projector.project({centre.x(), centre.y(), 0.0});
  if (!bottom) return Decision::kUnseen;
  // This also settles whether the centre is in view: the stream's bounds are pixel edges.
  if (!locate(bottom->stream, where)) return Decision::kUnsure;
  if (!(where.column >= 0 && where.row >= 0 && where.column < camera.streamWidth() &&
        where.row < camera.streamHeight())) {
    return Decision::kUnseen;
  }
  pixel = static_cast<int>(where.row) * camera.streamWidth() + static_cast<int>(where.column);
  return isFloorPixel(mask, pixel, camera.streamWidth()) ? Decision::kSeen : Decision::kUnseen;
}

// walkColumn's knot heights for each spacing (1 to 10 steps), up to the first at or above the top,
// and room for their projections, kept from cell to cell.
struct Knots {
  explicit Knots(int steps) {
    for (int spacing = 1; spacing <= 10; ++spacing) {
      std::vector<double>& list = heights[static_cast<std::size_t>(spacing)];
      for (int knot = spacing;; knot += spacing) {
        list.push_back(knot * kColumnStepM);
        if (knot >= steps) break;
      }
    }
  }
  std::array<std::vector<double>, 11> heights;
  std::vector<std::optional<FastProjector::Point>> points;
};

// centrePixel and walkColumn on fast projections, every step as they take it.
Decision fastColumn(const FastProjector& projector, const Camera& camera, ImageView mask,
                    const Eigen::Vector2d& centre, int steps, Knots& knots,
                    std::vector<std::uint32_t>& out) {
  std::optional<FastProjector::Point> bottom;
  WalkPoint previous;
  int pixel = 0;
  const Decision seen = fastCentrePixel(projector, camera, mask, centre, bottom, previous, pixel);
  if (seen != Decision::kSeen) return seen;
  out.push_back(static_cast<std::uint32_t>(pixel));
  if (steps == 0) return Decision::kSeen;
  const int width = camera.streamWidth();
  const int height = camera.streamHeight();
  const std::optional<FastProjector::Point> probe =
      projector.project({centre.x(), centre.y(), 0.1});
  int knot_steps = 1;
  if (probe) {
    // The reference's length lies within the two points' errors (and rounding) of this one, and
    // knotStepsFor is monotone: where both ends of that interval give the same spacing, so does it.
    const double length = (probe->stream - bottom->stream).norm();
    const double slack =
        probe->error_px + bottom->error_px + 4 * kUnitRoundoff * length + kDecisionMarginPx;
    knot_steps = knotStepsFor(length);
    if (knotStepsFor(length + slack) != knotStepsFor(std::max(length - slack, 0.0))) {
      return Decision::kUnsure;
    }
  }
  // walkColumn's knots, all projected at once.
  const std::vector<double>& heights = knots.heights[static_cast<std::size_t>(knot_steps)];
  knots.points.resize(heights.size());
  projector.projectColumn(centre.x(), centre.y(), heights, knots.points);
  Eigen::Vector2d previous_stream = bottom->stream;
  for (std::size_t k = 0; k < knots.points.size(); ++k) {
    const std::optional<FastProjector::Point>& next = knots.points[k];
    if (!next) return Decision::kSeen;
    Eigen::Vector2d end = next->stream;
    if (k + 1 == knots.points.size()) {
      // The top lies on this chord.
      const int knot = knot_steps * static_cast<int>(k + 1);
      const double fraction = static_cast<double>(steps - (knot - knot_steps)) / knot_steps;
      end = previous_stream + (next->stream - previous_stream) * fraction;
    }
    WalkPoint located;
    if (!locate(end, located) || !walkSegmentChecked(previous, located, width, height, out)) {
      return Decision::kUnsure;
    }
    previous = located;
    previous_stream = next->stream;
  }
  return Decision::kSeen;
}

CarveTable buildFloorTable(const Camera& camera, const MapGeometry& map, ImageView mask) {
  std::vector<std::uint64_t> edges;
  addPaperEdges(camera, map, mask, edges);
  const FastProjector projector(camera);
  std::optional<FastProjector::Point> bottom;
  for (int row = 0; row < map.height; ++row) {
    for (int column = 0; column < map.width; ++column) {
      const int cell = map.index(row, column);
      int pixel = 0;
      WalkPoint where;
      switch (fastCentrePixel(projector, camera, mask, map.cellCentre(row, column), bottom, where,
                              pixel)) {
        case Decision::kSeen:
          edges.push_back(edge(cell, pixel));
          break;
        case Decision::kUnsure:
          if (const std::optional<int> exact = centrePixel(camera, map, row, column, mask)) {
            edges.push_back(edge(cell, *exact));
          }
          break;
        case Decision::kUnseen:
          break;
      }
    }
  }
  return fromEdges(CarveRule::kAnyPixel, camera, map, edges);
}

CarveTable buildColumnTable(const Camera& camera, const MapGeometry& map, double column_height_m,
                            ImageView mask) {
  const int steps = columnSteps(column_height_m);
  std::vector<std::uint32_t> offsets(map.cellCount() + 1, 0);
  std::vector<std::uint32_t> pixels;
  std::vector<std::uint32_t> column_pixels;
  Knots knots(steps);
  const FastProjector projector(camera);
  for (int row = 0; row < map.height; ++row) {
    for (int column = 0; column < map.width; ++column) {
      const auto cell = static_cast<std::size_t>(map.index(row, column));
      offsets[cell + 1] = offsets[cell];
      const Eigen::Vector2d centre = map.cellCentre(row, column);
      column_pixels.clear();
      Decision seen = fastColumn(projector, camera, mask, centre, steps, knots, column_pixels);
      if (seen == Decision::kUnsure) {
        column_pixels.clear();
        seen = centrePixel(camera, map, row, column, mask) ? Decision::kSeen : Decision::kUnseen;
        if (seen == Decision::kSeen) walkColumn(camera, centre, steps, column_pixels);
      }
      if (seen == Decision::kUnseen) continue;
      appendSortedColumn(column_pixels, pixels);
      offsets[cell + 1] = static_cast<std::uint32_t>(pixels.size());
    }
  }
  return CarveTable(CarveRule::kEveryPixel, map, camera.streamWidth(), camera.streamHeight(),
                    std::move(offsets), std::move(pixels));
}

void checkArguments(const Camera& camera, double column_height_m, ImageView floor_mask) {
  if (!floor_mask.empty() &&
      (floor_mask.width != camera.streamWidth() || floor_mask.height != camera.streamHeight())) {
    throw std::invalid_argument("floor mask size differs from the stream's");
  }
  if (!(column_height_m >= 0.0)) throw std::invalid_argument("column height must be >= 0");
}

}  // namespace

FastProjector::FastProjector(const Camera& camera) : camera_(&camera) {
  const auto* tsai = dynamic_cast<const TsaiCamera*>(&camera.model());
  if (tsai == nullptr) return;
  tsai_ = &tsai->parameters();
  const TsaiParameters& p = *tsai_;
  kappa1_ = p.kappa1;
  if (p.kappa1 != 0.0) {
    const double q = 1.0 / (3.0 * p.kappa1);
    cardan_sq_ = std::sqrt(std::abs(q));
    cardan_inv_q2_ = 1.0 / (q * q);
  }
  // Within half the barrel limit Willson's cubic is far from its double root, where Cardan's
  // formula and Newton's method both lose accuracy; beyond it every point goes the exact way.
  max_ru2_fast_ = p.kappa1 < 0.0
                      ? 0.25 * tsai->maxUndistortedRadius() * tsai->maxUndistortedRadius()
                      : std::numeric_limits<double>::infinity();
  const Pose& pose = camera.model().pose();
  rotation_ = pose.rotation;
  translation_ = pose.translation;
  translation_sum_ = pose.translation.cwiseAbs().sum();
  units_per_metre_ = 1.0 / camera.metresPerUnit();
  inverse_focal_ = 1.0 / p.focal;
  // Sensor to stream pixels in one multiplication and one addition per axis: u_s = (sx Xd / dpx +
  // Cx - x0 + 0.5) W_s / w - 0.5, likewise v.
  const ImageRegion& region = camera.region();
  const double scale_x = camera.streamWidth() / region.width;
  const double scale_y = camera.streamHeight() / region.height;
  sensor_to_x_ = p.sx / p.dpx * scale_x;
  sensor_to_y_ = scale_y / p.dpy;
  offset_x_ = (p.cx - region.x0 + 0.5) * scale_x - 0.5;
  offset_y_ = (p.cy - region.y0 + 0.5) * scale_y - 0.5;
  pixels_per_mm_ = std::max(std::abs(sensor_to_x_), std::abs(sensor_to_y_));
  rounding_ = 16 * kUnitRoundoff *
              (std::max(scale_x, scale_y) * (std::abs(p.cx) + std::abs(p.cy) + std::abs(region.x0) +
                                             std::abs(region.y0) + 2.0) +
               std::abs(offset_x_) + std::abs(offset_y_) + 2.0);
  // Newton's starts over the a of the image and well round it (five times its undistorted
  // half-diagonal; points farther out go the exact way): a = kappa1 Ru^2 falls in [-1/27, 0]
  // within half the barrel limit. s(a) is smooth, so at this spacing a linear interpolation is
  // within about 1e-6 of it, and one Newton step then leaves about 1e-13.
  double a_end = 1.0;
  if (p.kappa1 > 0.0) {
    const double half_x = std::max(p.cx, p.width - p.cx) * p.dpx / std::abs(p.sx);
    const double half_y = std::max(p.cy, p.height - p.cy) * p.dpy;
    const double rd = std::hypot(half_x, half_y);
    const double ru = 5.0 * rd * (1.0 + p.kappa1 * rd * rd);
    a_end = p.kappa1 * ru * ru;
  } else if (p.kappa1 < 0.0) {
    a_start_ = -1.0 / 27.0;
    a_end = 0.0;
  }
  // Without distortion a = 0 and s = 1: a table of ones.
  const int starts = p.kappa1 == 0.0 ? 2 : 4096;
  start_scale_ = (starts - 1) / (a_end - a_start_);
  last_start_ = starts - 2;
  starts_.resize(static_cast<std::size_t>(starts));
  double s = 1.0;
  for (int i = 0; i < starts; ++i) {
    const double a = p.kappa1 == 0.0 ? 0.0 : a_start_ + i / start_scale_;
    // From the previous entry's s, to the last bit.
    for (int iteration = 0; iteration < 100; ++iteration) {
      const double step = (s * (1.0 + a * s * s) - 1.0) / (1.0 + 3.0 * a * s * s);
      s -= step;
      if (std::abs(step) <= 1e-16 * s) break;
    }
    starts_[static_cast<std::size_t>(i)] = s;
  }
}

std::optional<FastProjector::Point> FastProjector::exact(const Eigen::Vector3d& world_m) const {
  const std::optional<Eigen::Vector2d> stream = camera_->worldToStream(world_m);
  if (!stream) return std::nullopt;
  return Point{*stream, 0.0};
}

FastProjector::Column FastProjector::column(double wx, double wy) const {
  const Eigen::Matrix3d& r = rotation_;
  return {r(0, 0) * wx + r(0, 1) * wy + translation_.x(),
          r(1, 0) * wx + r(1, 1) * wy + translation_.y(),
          r(2, 0) * wx + r(2, 1) * wy + translation_.z(),
          std::abs(wx) + std::abs(wy) + translation_sum_};
}

FastProjector::Step FastProjector::fastStep(const Column& column, double wz,
                                            double coordinate_error) const {
  // Camera coordinates as CameraModel::worldToImage has them, up to rounding (coordinate_error).
  const Eigen::Matrix3d& r = rotation_;
  const double cx = column.x + r(0, 2) * wz;
  const double cy = column.y + r(1, 2) * wz;
  const double cz = column.z + r(2, 2) * wz;
  const double perspective = tsai_->focal / cz;
  const double xu = cx * perspective;
  const double yu = cy * perspective;
  const double ru2 = xu * xu + yu * yu;
  // Willson's cubic Ru = Rd (1 + kappa1 Rd^2) for s = Rd / Ru: s (1 + a s^2) = 1 with
  // a = kappa1 Ru^2, one Newton step from the table's start.
  const double a = kappa1_ * ru2;
  const double position = (a - a_start_) * start_scale_;
  const bool in_table = position >= 0.0 && position <= last_start_;
  const double clamped = position > 0.0 ? (position < last_start_ ? position : last_start_) : 0.0;
  const auto i = static_cast<std::size_t>(clamped);
  const double fraction = clamped - static_cast<double>(i);
  double s = starts_[i] + fraction * (starts_[i + 1] - starts_[i]);
  const double s2 = s * s;
  const double slope = 1.0 + 3.0 * a * s2;
  const double inverse_slope = 1.0 / slope;
  const double step = (s * (1.0 + a * s2) - 1.0) * inverse_slope;
  s -= step;
  // Quadratic convergence: after the step the error is (3 a s / slope) step^2.
  const double remaining = 3 * std::abs(a) * s * step * step * inverse_slope;
  // Bounds need only a bound on Ru, and |xu| + |yu| (at most 1.5 Ru) spares a square root.
  const double ru = std::abs(xu) + std::abs(yu);
  const bool usable =
      // In front of the camera and not so near its focal plane that rounding could say otherwise.
      cz > 4 * coordinate_error &&
      // Within half the barrel limit (also false for NaN), and where the table has a start.
      ru2 <= max_ru2_fast_ && in_table &&
      // Newton went the right way and is done (within kNewtonLeft); flat or falling means near
      // the barrel limit.
      slope > 0.25 && remaining <= kNewtonLeft * s;
  return {{xu * s * sensor_to_x_ + offset_x_, yu * s * sensor_to_y_ + offset_y_},
          ru,
          ru * s,
          ru2 * s * s,
          perspective,
          usable};
}

double FastProjector::cardanError(double rd) const {
  // How far the reference's Cardan formula may be from the true Rd (cancellation between its two
  // cube roots; over 2e7 random radii it stayed 13 times below this).
  if (kappa1_ > 0.0) {
    const double m = rd + cardan_sq_;  // bounds the larger cube root
    return 32 * kUnitRoundoff * (m + cardan_sq_ + m * m * m * m * m * cardan_inv_q2_ + rd);
  }
  if (kappa1_ < 0.0) return 64 * kUnitRoundoff * (4 * cardan_sq_ + rd);
  return 0.0;
}

double FastProjector::errorBound(double coordinate_error, double ru, double rd,
                                 double perspective) const {
  // The error of s: rounding in the cubic (s + |a| s^3 + 1 < 3 where this path runs; slope > 1/4)
  // and what Newton left (at most kNewtonLeft s, s < 1.1).
  constexpr double kRatioError = 48 * kUnitRoundoff + 1.1 * kNewtonLeft;
  // On the sensor: R X + T's rounding through the perspective division and the lens (which
  // stretches at most twice where this path runs), Newton's error, Cardan's, and rounding.
  const double sensor_error = 2 * coordinate_error * (2.0 + ru * inverse_focal_) * perspective +
                              ru * kRatioError + cardanError(rd) + 16 * kUnitRoundoff * ru;
  // Frame buffer and stream coordinates are rounded in a different order here than in
  // TsaiCamera::cameraToPixel and Camera::calibrationToStream: a few units in their last places
  // (|Xd| + |Yd| = s (|xu| + |yu|) = rd).
  return 2 * pixels_per_mm_ * sensor_error + 32 * kUnitRoundoff * pixels_per_mm_ * rd + rounding_;
}

bool FastProjector::nearCentre(double rd2, double rd) const {
  // Near the principal point the reference's own error can exceed Rd (its radii are then odd).
  const double cardan = cardanError(rd);
  return kappa1_ != 0.0 && !(rd2 > 4 * cardan * cardan);
}

std::optional<FastProjector::Point> FastProjector::project(const Eigen::Vector3d& world_m) const {
  if (tsai_ == nullptr) return exact(world_m);
  const Column base = column(world_m.x() * units_per_metre_, world_m.y() * units_per_metre_);
  const double wz = world_m.z() * units_per_metre_;
  const double coordinate_error = 8 * kUnitRoundoff * (base.size + std::abs(wz));
  const Step step = fastStep(base, wz, coordinate_error);
  if (!step.usable || nearCentre(step.rd2, step.rd)) return exact(world_m);
  const double error = errorBound(coordinate_error, step.ru, step.rd, step.perspective);
  if (!(error <= kFastProjectionTolerancePx)) return exact(world_m);
  return Point{step.stream, error};
}

void FastProjector::projectColumn(double x_m, double y_m, std::span<const double> z_m,
                                  std::span<std::optional<Point>> out) const {
  if (tsai_ == nullptr) {
    for (std::size_t k = 0; k < z_m.size(); ++k) out[k] = exact({x_m, y_m, z_m[k]});
    return;
  }
  const Column base = column(x_m * units_per_metre_, y_m * units_per_metre_);
  double highest = 0.0;
  for (const double z : z_m) highest = std::max(highest, std::abs(z));
  const double coordinate_error = 8 * kUnitRoundoff * (base.size + highest * units_per_metre_);
  // One bound for the whole column, from the largest ru, rd and perspective of its points (the
  // bound grows with each), spares each point its own.
  bool usable = true;
  double ru = 0.0, rd = 0.0, perspective = 0.0;
  double rd2 = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < z_m.size(); ++k) {
    const Step step = fastStep(base, z_m[k] * units_per_metre_, coordinate_error);
    out[k] = Point{step.stream, 0.0};
    usable &= step.usable;
    ru = std::max(ru, step.ru);
    rd = std::max(rd, step.rd);
    rd2 = std::min(rd2, step.rd2);
    perspective = std::max(perspective, step.perspective);
  }
  const double error = errorBound(coordinate_error, ru, rd, perspective);
  if (usable && !nearCentre(rd2, rd) && error <= kFastProjectionTolerancePx) {
    for (std::size_t k = 0; k < z_m.size(); ++k) out[k]->error_px = error;
    return;
  }
  // Some point needs more care: each on its own.
  for (std::size_t k = 0; k < z_m.size(); ++k) out[k] = project({x_m, y_m, z_m[k]});
}

CarveTable buildCarveTable(const Camera& camera, const MapGeometry& map, double column_height_m,
                           ImageView floor_mask) {
  checkArguments(camera, column_height_m, floor_mask);
  if (column_height_m == 0.0) return buildFloorTable(camera, map, floor_mask);
  return buildColumnTable(camera, map, column_height_m, floor_mask);
}

CarveTable buildCarveTableReference(const Camera& camera, const MapGeometry& map,
                                    double column_height_m, ImageView floor_mask) {
  checkArguments(camera, column_height_m, floor_mask);
  if (column_height_m == 0.0) return buildFloorTableReference(camera, map, floor_mask);
  return buildColumnTableReference(camera, map, column_height_m, floor_mask);
}

}  // namespace occmap
