#include "fuzz/calibration_use.h"

#include <cmath>

#include "core/camera.h"
#include "core/carve_table.h"
#include "fuzz/fuzz_target.h"

namespace occmap::fuzz {
namespace {

// Small on purpose: a stream of 40 x 30 pixels (the calibration frame scaled, as binning does) and
// a 4 x 4 m map of 16 x 16 cells around the world origin, so that one input takes milliseconds
// while every step of table building still runs. A calibration frame of 65536 pixels a side is
// valid and would only make each input slow, not find more.
constexpr int kStreamWidth = 40;
constexpr int kStreamHeight = 30;
const MapGeometry kMap{-2.0, -2.0, 0.25, 16, 16};

void checkTable(const CarveTable& table) {
  const std::uint32_t pixels = kStreamWidth * kStreamHeight;
  for (std::size_t cell = 0; cell < kMap.cellCount(); ++cell) {
    std::uint32_t previous = 0;
    bool first = true;
    for (const std::uint32_t pixel : table.pixelsOf(cell)) {
      require(pixel < pixels, "a carve table names only pixels of the stream");
      require(first || pixel > previous, "a cell's pixels are ascending, without repeats");
      previous = pixel;
      first = false;
    }
  }
}

}  // namespace

void useCalibration(const std::shared_ptr<const CameraModel>& model, LengthUnit units) {
  const Camera camera(model, units, kStreamWidth, kStreamHeight);
  // CameraModel's promise: "no result" is an empty optional, never a number.
  for (const Eigen::Vector2d& corner :
       {Eigen::Vector2d(-2, -2), Eigen::Vector2d(2, -2), Eigen::Vector2d(-2, 2),
        Eigen::Vector2d(2, 2), Eigen::Vector2d(0, 0)}) {
    if (const auto pixel = camera.worldToStream(Eigen::Vector3d(corner.x(), corner.y(), 0.0))) {
      require(pixel->allFinite(), "a world point's pixel, when there is one, is finite");
    }
  }
  for (const Eigen::Vector2d& pixel :
       {Eigen::Vector2d(0, 0), Eigen::Vector2d(kStreamWidth - 1, kStreamHeight - 1),
        Eigen::Vector2d(kStreamWidth / 2.0, kStreamHeight / 2.0)}) {
    if (const auto floor = camera.streamToPlane(pixel, 0.0)) {
      require(floor->allFinite(), "a pixel's floor point, when there is one, is finite");
    }
  }
  for (const double column_height_m : {0.0, 0.3}) {
    checkTable(buildCarveTable(camera, kMap, column_height_m));
  }
}

}  // namespace occmap::fuzz
