// Real calibration files (PETS 2009, EPFL Terrace) through the loaders and the camera models: they
// load, they put the cameras above the floor, pixels and floor points map back and forth exactly,
// and the EPFL ground truth lands on the people in the EPFL masks. Needs ../shared/data; skips
// (exit 77) when it is absent.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/calibration_file.h"
#include "core/camera.h"
#include "core/tsai_camera.h"

namespace occmap {
namespace {

namespace fs = std::filesystem;

const fs::path kData = OCCMAP_SHARED_DATA;
const fs::path kCalib = kData / "calib";
const fs::path kTerrace = kData / "epfl-terrace";

#define SKIP_WITHOUT(folder)                                                            \
  do {                                                                                  \
    if (!fs::is_directory(folder)) {                                                    \
      GTEST_SKIP() << "reference data folder " << (folder)                              \
                   << " is missing (set OCCMAP_SHARED_DATA to the shared data folder)"; \
    }                                                                                   \
  } while (false)

std::vector<fs::path> petsFiles() {
  std::vector<fs::path> files;
  for (int view = 1; view <= 8; ++view) {
    char name[32];
    std::snprintf(name, sizeof name, "View_%03d.xml", view);
    files.push_back(kCalib / "pets2009" / name);
  }
  return files;
}

std::vector<fs::path> terraceFiles() {
  std::vector<fs::path> files;
  for (int camera = 0; camera < 4; ++camera) {
    files.push_back(kTerrace / "calib" / ("terrace-tsai-c" + std::to_string(camera) + ".xml"));
  }
  return files;
}

std::vector<fs::path> allFiles() {
  std::vector<fs::path> files = petsFiles();
  for (const fs::path& file : terraceFiles()) files.push_back(file);
  return files;
}

TEST(RealCalibration, EveryFileLoadsWithItsCameraAboveTheFloor) {
  SKIP_WITHOUT(kCalib);
  SKIP_WITHOUT(kTerrace);
  for (const fs::path& file : allFiles()) {
    SCOPED_TRACE(file.string());
    const LoadedCalibration loaded = loadCalibration(file);
    EXPECT_EQ(loaded.kind, "tsai");
    EXPECT_EQ(loaded.units, LengthUnit::kMillimetre);
    const auto& camera = dynamic_cast<const TsaiCamera&>(*loaded.model);
    const TsaiParameters& p = camera.parameters();
    const Eigen::Vector3d centre = camera.pose().centre();
    EXPECT_GT(centre.z(), 0.0) << "camera centre below the floor";
    // How far the files' dpx is from Willson's definition (the loader allows 1e-6).
    const double dpx_difference = std::abs(p.dpx - p.dx * p.ncx / p.nfx) / p.dpx;
    std::printf("%-22s %dx%d centre (%.0f, %.0f, %.0f) mm, kappa1 %+.3e, dpx vs dx*ncx/nfx %.1e\n",
                file.filename().c_str(), p.width, p.height, centre.x(), centre.y(), centre.z(),
                p.kappa1, dpx_difference);
  }
}

// Pixels on a 17 x 17 grid over the image, edges included, through the plane at height z and back.
// Floor points come back within 1e-6 mm up to 1 km away. Beyond, near the horizon, one pixel spans
// kilometres of floor and the rounding of a double in the pixel (1e-12 px) alone moves the point by
// more: there the bound is 1e-12 of the distance (on PETS View_004, 15 km: 8e-6 mm).
void expectRoundTrips(const CameraModel& camera, double z, const std::string& name) {
  constexpr int kSteps = 16;
  int with_plane_point = 0;
  double worst_pixel = 0;
  double worst_world = 0;
  double worst_world_excess = 0;  // error over its bound; must stay < 1
  double farthest = 0;
  for (int i = 0; i <= kSteps; ++i) {
    for (int j = 0; j <= kSteps; ++j) {
      const Eigen::Vector2d pixel((camera.width() - 1) * i / double{kSteps},
                                  (camera.height() - 1) * j / double{kSteps});
      const std::optional<PlanePoint> plane = camera.imageToPlane(pixel, z);
      if (!plane) continue;  // above the horizon, or past the barrel limit
      ++with_plane_point;
      const std::optional<ImagePoint> image = camera.worldToImage(plane->world);
      ASSERT_TRUE(image) << name << ": pixel " << pixel.transpose() << " sees "
                         << plane->world.transpose() << ", which has no image";
      worst_pixel = std::max(worst_pixel, (image->pixel - pixel).norm());
      const std::optional<PlanePoint> back = camera.imageToPlane(image->pixel, z);
      ASSERT_TRUE(back) << name << ": pixel " << image->pixel.transpose() << " has no plane point";
      const double world_error = (back->world - plane->world).norm();
      worst_world = std::max(worst_world, world_error);
      worst_world_excess =
          std::max(worst_world_excess, world_error / std::max(1e-6, 1e-12 * plane->depth));
      farthest = std::max(farthest, plane->depth);
    }
  }
  const int grid = (kSteps + 1) * (kSteps + 1);
  std::printf(
      "%-22s z=%4.0f: %3d/%d pixels meet the plane (depth up to %.0f mm), worst %.1e px, "
      "%.1e mm\n",
      name.c_str(), z, with_plane_point, grid, farthest, worst_pixel, worst_world);
  EXPECT_GE(2 * with_plane_point, grid) << name << ": fewer than half the pixels see the plane";
  EXPECT_LT(worst_pixel, 1e-6) << name << ": image -> plane -> image, pixels";
  EXPECT_LT(worst_world_excess, 1.0)
      << name << ": plane -> image -> plane off by more than max(1e-6 mm, 1e-12 x distance); worst "
      << worst_world << " mm";
}

TEST(RealCalibration, PixelsAndFloorPointsRoundTrip) {
  SKIP_WITHOUT(kCalib);
  SKIP_WITHOUT(kTerrace);
  for (const fs::path& file : allFiles()) {
    const LoadedCalibration loaded = loadCalibration(file);
    expectRoundTrips(*loaded.model, 0.0, file.filename().string());
    expectRoundTrips(*loaded.model, 1000.0, file.filename().string());
  }
}

TEST(RealCalibration, TerraceCalibrationFrameIs720x576) {
  SKIP_WITHOUT(kTerrace);
  for (const fs::path& file : terraceFiles()) {
    const LoadedCalibration loaded = loadCalibration(file);
    EXPECT_EQ(loaded.model->width(), 720) << file;
    EXPECT_EQ(loaded.model->height(), 576) << file;
  }
}

TEST(RealCalibration, PetsView007HasABarrelLimit) {
  SKIP_WITHOUT(kCalib);
  const LoadedCalibration loaded = loadCalibration(kCalib / "pets2009" / "View_007.xml");
  const auto& camera = dynamic_cast<const TsaiCamera&>(*loaded.model);
  const TsaiParameters& p = camera.parameters();
  ASSERT_LT(p.kappa1, 0.0);
  ASSERT_TRUE(std::isfinite(camera.maxUndistortedRadius()));
  // A point whose undistorted sensor radius Ru = f |(xc, yc)| / zc is just inside or past the
  // limit.
  const Pose& pose = camera.pose();
  auto worldAt = [&](double undistorted_radius) {
    const double depth = 5000;
    const Eigen::Vector3d in_camera(undistorted_radius / p.focal * depth * 0.6,
                                    undistorted_radius / p.focal * depth * 0.8, depth);
    return Eigen::Vector3d(pose.rotation.transpose() * (in_camera - pose.translation));
  };
  EXPECT_TRUE(camera.worldToImage(worldAt(0.999 * camera.maxUndistortedRadius())));
  EXPECT_FALSE(camera.worldToImage(worldAt(1.001 * camera.maxUndistortedRadius())));
  EXPECT_FALSE(camera.worldToImage(worldAt(3.0 * camera.maxUndistortedRadius())));
  // The limit lies inside this camera's picture: its top-left corner pixel is past it, so it has
  // no ray, while the image centre has one.
  const double corner_radius = std::hypot(p.dpx * (0 - p.cx) / p.sx, p.dpy * (0 - p.cy));
  std::printf(
      "View_007: barrel limit at distorted radius %.3f mm (%.0f px), top-left corner at "
      "%.3f mm\n",
      camera.maxDistortedRadius(), camera.maxDistortedRadius() / p.dpx, corner_radius);
  EXPECT_GT(corner_radius, camera.maxDistortedRadius());
  EXPECT_FALSE(camera.imageToRay(Eigen::Vector2d(0, 0)));
  EXPECT_TRUE(camera.imageToRay(Eigen::Vector2d(p.cx, p.cy)));
}

struct Annotation {
  int index;
  int source_frame;
  double x_mm;
  double y_mm;
};

std::vector<Annotation> readGroundTruth(const fs::path& file) {
  std::ifstream in(file);
  std::vector<Annotation> annotations;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    fields.imbue(std::locale::classic());
    Annotation a{};
    if (fields >> a.index >> a.source_frame >> a.x_mm >> a.y_mm) annotations.push_back(a);
  }
  return annotations;
}

// Whether the mask is white (a person) within `radius` pixels of `at`.
bool whiteNear(const cv::Mat& mask, const Eigen::Vector2d& at, int radius) {
  const int u0 = static_cast<int>(std::lround(at.x()));
  const int v0 = static_cast<int>(std::lround(at.y()));
  for (int v = v0 - radius; v <= v0 + radius; ++v) {
    for (int u = u0 - radius; u <= u0 + radius; ++u) {
      if (u < 0 || v < 0 || u >= mask.cols || v >= mask.rows) continue;
      if ((u - at.x()) * (u - at.x()) + (v - at.y()) * (v - at.y()) > radius * radius) continue;
      if (mask.at<std::uint8_t>(v, u) > 127) return true;
    }
  }
  return false;
}

// The EPFL annotations are people's floor positions. Projected at a person's middle (900 mm) into
// each camera's foreground mask (360x288: half the 720x576 calibration frame, a scale mapped by
// occmap::Camera), they land on the person. This checks loader, model and stream mapping on real
// data at once.
TEST(RealCalibration, TerraceGroundTruthLandsOnThePeopleInTheMasks) {
  SKIP_WITHOUT(kTerrace);
  constexpr double kMiddleOfAPersonMm = 900;
  constexpr int kRadius = 6;
  const std::vector<Annotation> annotations = readGroundTruth(kTerrace / "gt.txt");
  ASSERT_FALSE(annotations.empty()) << "no annotations in " << kTerrace / "gt.txt";
  std::vector<Camera> cameras;
  for (const fs::path& file : terraceFiles()) {
    const LoadedCalibration loaded = loadCalibration(file);
    cameras.emplace_back(loaded.model, loaded.units, 360, 288);
  }
  std::vector<int> hits(cameras.size(), 0);
  std::vector<int> in_image(cameras.size(), 0);
  int shifted_hits = 0;
  int total_hits = 0;
  for (const Annotation& a : annotations) {
    int cameras_in_image = 0;
    int cameras_hit = 0;
    std::string row;
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      char name[16];
      std::snprintf(name, sizeof name, "%06d.png", a.index);
      const fs::path mask_file = kTerrace / "masks" / ("c" + std::to_string(c)) / name;
      const cv::Mat mask = cv::imread(mask_file.string(), cv::IMREAD_GRAYSCALE);
      ASSERT_FALSE(mask.empty()) << "cannot read " << mask_file;
      ASSERT_EQ(mask.cols, 360);
      ASSERT_EQ(mask.rows, 288);
      const std::optional<Eigen::Vector2d> pixel =
          cameras[c].worldToStream(Eigen::Vector3d(a.x_mm, a.y_mm, kMiddleOfAPersonMm) / 1000.0);
      char cell[64];
      if (!pixel || !cameras[c].pixelIndexAt(*pixel)) {
        std::snprintf(cell, sizeof cell, "  c%zu outside        ", c);
        row += cell;
        continue;
      }
      ++cameras_in_image;
      ++in_image[c];
      const bool hit = whiteNear(mask, *pixel, kRadius);
      cameras_hit += hit ? 1 : 0;
      hits[c] += hit ? 1 : 0;
      total_hits += hit ? 1 : 0;
      // Control: the same person 1 m away must mostly miss, or this test could not see an error.
      const std::optional<Eigen::Vector2d> shifted = cameras[c].worldToStream(
          Eigen::Vector3d(a.x_mm + 700, a.y_mm + 700, kMiddleOfAPersonMm) / 1000.0);
      shifted_hits += shifted && whiteNear(mask, *shifted, kRadius) ? 1 : 0;
      std::snprintf(cell, sizeof cell, "  c%zu (%5.1f,%5.1f) %s", c, pixel->x(), pixel->y(),
                    hit ? "hit " : "MISS");
      row += cell;
    }
    std::printf("annotation %d (%6.0f, %6.0f) mm:%s\n", a.index, a.x_mm, a.y_mm, row.c_str());
    // Every annotated person stands where at least two cameras see it. Annotations 2 and 3 (the
    // person entering at x < 1 m) fall outside c0's and c3's pictures, whose masks are empty then:
    // there, "3 of 4" cannot hold, and the rule is every camera that has the person in its image.
    EXPECT_GE(cameras_in_image, 2) << "annotation " << a.index << " is in fewer than 2 images";
    EXPECT_GE(cameras_hit, std::min(3, cameras_in_image))
        << "annotation " << a.index << " at (" << a.x_mm << ", " << a.y_mm << ") mm lands on a "
        << "person in only " << cameras_hit << " of the " << cameras_in_image
        << " cameras whose image it falls in";
  }
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    std::printf("camera c%zu: %d of %d annotations in its image land on a person\n", c, hits[c],
                in_image[c]);
  }
  std::printf("control, every annotation moved by (0.7, 0.7) m: %d hits against %d\n", shifted_hits,
              total_hits);
  EXPECT_LT(2 * shifted_hits, total_hits) << "the check does not tell right from wrong positions";
}

}  // namespace
}  // namespace occmap
