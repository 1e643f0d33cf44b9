#include "fuzz/calibration_use.h"

#include <cmath>

#include "config/calibration_file.h"
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

void useOpenCvCalibration(OpenCvParameters p) {
  const bool size_from_stream = p.width == 0 && p.height == 0;
  require(
      size_from_stream || (p.width >= 1 && p.width <= 65536 && p.height >= 1 && p.height <= 65536),
      "an accepted image is 1..65536 pixels a side, or leaves its size (both sides) out");
  require(std::isfinite(p.fx) && p.fx > 0 && std::isfinite(p.fy) && p.fy > 0,
          "accepted focal lengths are finite and > 0");
  require(std::isfinite(p.cx) && std::isfinite(p.cy) && p.rvec.allFinite() && p.tvec.allFinite(),
          "accepted parameters are finite");
  for (const double k : p.distortion) require(std::isfinite(k), "accepted distortion is finite");
  require(p.world_frame == WorldFrame::kRightHanded, "a file alone gives OpenCV's world frame");
  for (const WorldFrame frame : {WorldFrame::kRightHanded, WorldFrame::kLeftHanded}) {
    p.world_frame = frame;
    const LoadedCalibration loaded{std::make_shared<OpenCvCamera>(p), LengthUnit::kMetre, "opencv"};
    require(loaded.sizeFromStream() == size_from_stream,
            "the model leaves its size to the stream exactly when the file does");
    useCalibration(loaded.modelFor(640, 480), loaded.units);
  }
}

}  // namespace occmap::fuzz
