#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "core/camera.h"
#include "core/image.h"
#include "core/map_geometry.h"

namespace occmap {

struct TsaiParameters;

// How a camera's pixels decide one of its cells.
enum class CarveRule : std::uint8_t {
  // column_height_m = 0, the paper's floor-point carving: the cell is cleared when any of its
  // pixels
  // is unchanged (a clear ray reaches the floor inside the cell).
  kAnyPixel,
  // column_height_m > 0, column carving: the cell is cleared only when every pixel on the image of
  // its
  // vertical column, from the floor up to column_height_m, is unchanged.
  kEveryPixel,
};

// One camera's look-up table from map cells to the stream pixels that decide them, computed once
// from calibration + map geometry (+ floor mask), never in the frame loop.
//
// Floor mode (column_height_m = 0) holds the paper's table, each floor pixel's centre to the cell
// its ray meets on the floor, and more: every cell whose centre projects into a floor pixel also
// gets that pixel, so far from the camera, where cells fall between pixel centres, no cell the
// camera sees is left without a pixel (the paper's holes). Column mode (column_height_m > 0) gives
// every such cell the pixels crossed by the image of its vertical column (see buildCarveTable).
//
// A camera sees a cell when some floor pixel decides it: always when the cell's centre projects
// into an in-bounds floor pixel (no holes), and in floor mode also when a floor pixel's centre ray
// meets the floor inside the cell (at the image's and the mask's borders).
class CarveTable {
 public:
  CarveTable() = default;
  CarveTable(CarveRule rule, const MapGeometry& map, int image_width, int image_height,
             std::vector<std::uint32_t> cell_offsets, std::vector<std::uint32_t> cell_pixels);

  CarveRule rule() const { return rule_; }
  const MapGeometry& map() const { return map_; }
  int imageWidth() const { return image_width_; }
  int imageHeight() const { return image_height_; }

  bool sees(std::size_t cell) const { return offsets_[cell + 1] > offsets_[cell]; }
  // Stream pixel indices (v * width + u) that decide the cell, ascending, without repeats.
  std::span<const std::uint32_t> pixelsOf(std::size_t cell) const {
    return {pixels_.data() + offsets_[cell], pixels_.data() + offsets_[cell + 1]};
  }
  std::size_t cellsInView() const;
  std::size_t entries() const { return pixels_.size(); }

 private:
  CarveRule rule_ = CarveRule::kAnyPixel;
  MapGeometry map_;
  int image_width_ = 0;
  int image_height_ = 0;
  std::vector<std::uint32_t> offsets_;  // map_.cellCount() + 1 entries (CSR)
  std::vector<std::uint32_t> pixels_;
};

// Column carving follows the image of each cell's column from the floor up to ceil(h / step) * step
// and takes every pixel it crosses; the knots it follows sit at heights that depend on the cell
// only, never on h, so a lower column's pixels are always a subset of a higher one's: carving is
// monotone in column_height_m, and heights are honoured rounded up to the step (1 cm).
inline constexpr double kColumnStepM = 0.01;

// `floor_mask`, if not empty, has the stream's size; non-zero marks floor pixels, the only ones
// that may clear a cell. Throws std::invalid_argument on a mask of another size or a negative
// height.
//
// Every decision of the table (the pixel a cell's centre or a knot falls in, the side of a pixel
// corner a piece of column passes) is taken on knots projected by FastProjector, and only where
// each knot lies at least kDecisionMarginPx from the pixel edges and corners that decide it; a cell
// where one does not is built again from Camera::worldToStream itself. So the table is
// buildCarveTableReference's, pixel for pixel, at a fraction of its cost.
CarveTable buildCarveTable(const Camera& camera, const MapGeometry& map, double column_height_m,
                           ImageView floor_mask = {});

// The same table the straightforward way: every knot through Camera::worldToStream (Cardan's
// formula each time). Several times slower; kept as the definition buildCarveTable is tested
// against (carve_table_test, bench/table_build_bench).
CarveTable buildCarveTableReference(const Camera& camera, const MapGeometry& map,
                                    double column_height_m, ImageView floor_mask = {});

// A fast projection is used only when it lies within this of worldToStream's result (stream
// pixels), and decisions are taken on it only this far from their pixel edges and corners: a
// thousand times the error, so that no decision can come out otherwise than the reference's.
inline constexpr double kFastProjectionTolerancePx = 1e-9;
inline constexpr double kDecisionMarginPx = 1e-6;

// World points to stream pixels for the table build, which projects some twenty points up each
// cell's column. For Tsai's model the distortion is solved by one step of Newton's method from a
// start looked up in a table (a few multiplications and a division) instead of Cardan's formula
// (two cube roots and a hypot), and the result comes with a bound on its distance from
// worldToStream's. A point the step leaves unsure (behind or near the focal plane, past half the
// barrel limit, far outside the image, at the principal point where Cardan's own rounding is of
// the order of the radius) or whose bound exceeds kFastProjectionTolerancePx, and every point of
// another lens model, goes through worldToStream itself. Exposed for tests.
class FastProjector {
 public:
  explicit FastProjector(const Camera& camera);

  struct Point {
    Eigen::Vector2d stream;
    double error_px;  // |stream - worldToStream(world)| <= error_px; 0 when it is that result
  };
  // Empty exactly when worldToStream(world_m) is.
  std::optional<Point> project(const Eigen::Vector3d& world_m) const;
  // project() for the points (x, y, z_m[k]) of one vertical column, into out[k] (as many as
  // z_m), computed together so that the processor overlaps their arithmetic, and under one bound
  // (the largest of theirs).
  void projectColumn(double x_m, double y_m, std::span<const double> z_m,
                     std::span<std::optional<Point>> out) const;

 private:
  // R X + T of a column's floor point (file units), and |X|_1 + |T|_1 for the bound on its
  // rounding: the points above it add the rotation's last column times their height.
  struct Column {
    double x, y, z;
    double size;
  };
  Column column(double wx, double wy) const;
  // The fast path for the point `wz` above a column's floor point, without a branch the processor
  // could mispredict; camera coordinates may be off by coordinate_error.
  struct Step {
    Eigen::Vector2d stream;
    double ru;           // |xu| + |yu|, at least the undistorted radius
    double rd;           // ru s, at least the distorted radius
    double rd2;          // the distorted radius squared
    double perspective;  // focal / zc
    bool usable;         // false: the point must go through worldToStream
  };
  Step fastStep(const Column& column, double wz, double coordinate_error) const;
  // A bound on the distance of fastStep's result from worldToStream's, growing with each argument.
  double errorBound(double coordinate_error, double ru, double rd, double perspective) const;
  double cardanError(double rd) const;
  // Where the reference's own rounding is of the order of Rd: the exact path decides.
  bool nearCentre(double rd2, double rd) const;
  // What Newton's step may leave of s, relative.
  static constexpr double kNewtonLeft = 1e-13;

  std::optional<Point> exact(const Eigen::Vector3d& world_m) const;

  const Camera* camera_;
  const TsaiParameters* tsai_ = nullptr;  // null: every point goes through worldToStream
  Eigen::Matrix3d rotation_;
  Eigen::Vector3d translation_;
  double units_per_metre_ = 1.0;
  double inverse_focal_ = 1.0;
  double kappa1_ = 0.0;
  double max_ru2_fast_ = 0;  // the fast path's limit on Ru^2 (kappa1 < 0: half the barrel limit)
  double cardan_sq_ = 0;     // sqrt(|q|) of Willson's cubic, q = 1 / (3 kappa1)
  double cardan_inv_q2_ = 0;
  double translation_sum_ = 0;  // |T|_1, for the bound on the rounding of R X + T
  double sensor_to_x_ = 0;      // distorted sensor coordinates (file units) to stream pixels
  double sensor_to_y_ = 0;
  double offset_x_ = 0;
  double offset_y_ = 0;
  double pixels_per_mm_ = 0;  // the larger of |sensor_to_x_|, |sensor_to_y_|
  double rounding_ = 0;       // the constant terms' share of the bound on rounding
  // Newton's starts: s = Rd / Ru of Willson's cubic against a = kappa1 Ru^2, at a_start_ +
  // i / start_scale_ over the range of a the image covers, interpolated linearly.
  std::vector<double> starts_;
  double a_start_ = 0.0;
  double start_scale_ = 1.0;
  double last_start_ = 0.0;  // the highest position that has a next entry to interpolate to
};

// Every stream pixel whose square the straight segment from a to b (stream pixel coordinates)
// passes through, in order; pixels out of bounds are skipped. Exposed for tests.
void forEachPixelOnSegment(const Eigen::Vector2d& a, const Eigen::Vector2d& b, int width,
                           int height, std::vector<std::uint32_t>& out);

}  // namespace occmap
