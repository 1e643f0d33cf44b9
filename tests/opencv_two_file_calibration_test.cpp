// OpenCV calibrations as the public multi-camera data sets ship them: cv::FileStorage XML, the
// intrinsics and the extrinsics in two files (WILDTRACK, MultiviewX), no image size (it comes from
// the stream), and MultiviewX's left-handed world, where every floor point has a negative depth
// that cv::projectPoints ignores. Each loads into the camera cv::projectPoints describes; each slip
// is refused naming its file, line and field.
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/calibration_file.h"
#include "config/config.h"
#include "config/input_error.h"
#include "config/rig.h"
#include "input_error_of.h"
#include "left_handed_extrinsics.h"
#include "temporary_folder.h"
#include "tsai_xml.h"

namespace occmap {
namespace {

using testing::errorOf;
using testing::says;

namespace fs = std::filesystem;
using testing::TemporaryFolder;

const cv::Mat kCameraMatrix =
    (cv::Mat_<double>(3, 3) << 1743.4, 0, 934.5, 0, 1735.1, 444.4, 0, 0, 1);
const cv::Mat kDistortion = (cv::Mat_<double>(1, 5) << -0.43, 0.25, 0.0012, -0.0007, -0.06);

// Written by cv::FileStorage itself, so that the test reads the real format.
fs::path writeIntrinsics(const fs::path& file, bool with_size) {
  cv::FileStorage storage(file.string(), cv::FileStorage::WRITE);
  if (with_size) storage << "image_width" << 1920 << "image_height" << 1080;
  storage << "camera_matrix" << kCameraMatrix << "distortion_coefficients" << kDistortion;
  return file;
}

// WILDTRACK's extrinsics files: each vector as numbers between blanks, written by hand.
std::string extrinsicsXml(const cv::Vec3d& rvec, const cv::Vec3d& tvec) {
  char text[512];
  std::snprintf(text, sizeof text,
                "<?xml version=\"1.0\"?>\n<opencv_storage>\n<rvec>%.17g %.17g %.17g</rvec>\n"
                "<tvec>%.17g %.17g %.17g</tvec>\n</opencv_storage>\n",
                rvec[0], rvec[1], rvec[2], tvec[0], tvec[1], tvec[2]);
  return text;
}

// A camera 3 m above the floor looking down at it and forward: floor points in front of it.
const cv::Vec3d kRvec(-2.2, 0.15, -0.1);
const cv::Vec3d kTvec(-0.6, 1.2, 4.5);

std::vector<cv::Point3d> floorPoints() {
  std::vector<cv::Point3d> points;
  for (double x = -2; x <= 2; x += 0.5) {
    for (double y = 1; y <= 5; y += 0.5) points.emplace_back(x, y, 0);
  }
  return points;
}

// Every floor point the camera images lands where cv::projectPoints puts it, in front of it.
void expectProjectsLikeOpenCv(const CameraModel& model, const cv::Vec3d& rvec,
                              const cv::Vec3d& tvec) {
  const std::vector<cv::Point3d> points = floorPoints();
  std::vector<cv::Point2d> expected;
  cv::projectPoints(points, rvec, tvec, kCameraMatrix, kDistortion, expected);
  int compared = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto image = model.worldToImage({points[i].x, points[i].y, points[i].z});
    if (!image) continue;  // past the lens model's valid radius
    EXPECT_NEAR(image->pixel.x(), expected[i].x, 1e-6) << i;
    EXPECT_NEAR(image->pixel.y(), expected[i].y, 1e-6) << i;
    EXPECT_GT(image->depth, 0.0) << i;
    ++compared;
  }
  EXPECT_GT(compared, static_cast<int>(points.size()) / 2);
}

TEST(OpenCvXml, OneFileReadsAsItsYamlTwin) {
  const TemporaryFolder folder;
  const fs::path xml = folder.file("c0.xml");
  {
    cv::FileStorage storage(xml.string(), cv::FileStorage::WRITE);
    storage << "image_width" << 1920 << "image_height" << 1080 << "camera_matrix" << kCameraMatrix
            << "distortion_coefficients" << kDistortion << "rvec" << cv::Mat(kRvec) << "tvec"
            << cv::Mat(kTvec);
  }
  const LoadedCalibration loaded = loadCalibration(xml);
  EXPECT_EQ(loaded.kind, "opencv");
  EXPECT_EQ(loaded.units, LengthUnit::kMetre);
  EXPECT_FALSE(loaded.sizeFromStream());
  EXPECT_EQ(loaded.model->width(), 1920);
  expectProjectsLikeOpenCv(*loaded.model, kRvec, kTvec);
}

TEST(OpenCvXml, IntrinsicsAndExtrinsicsInTwoFilesWithoutImageSize) {
  const TemporaryFolder folder;
  const fs::path intrinsics = writeIntrinsics(folder.file("intr_C1.xml"), false);
  const fs::path extrinsics = folder.write("extr_C1.xml", extrinsicsXml(kRvec, kTvec));
  const LoadedCalibration loaded =
      loadCalibration(CalibrationFiles{intrinsics, extrinsics}, LengthUnit::kMetre);
  EXPECT_TRUE(loaded.sizeFromStream());
  const auto sized = loaded.modelFor(1920, 1080);
  EXPECT_EQ(sized->width(), 1920);
  EXPECT_EQ(sized->height(), 1080);
  expectProjectsLikeOpenCv(*sized, kRvec, kTvec);

  // The config says so as {intrinsics, extrinsics}, paths from the config's folder.
  const Config config = parseConfig(
      "map: {origin_m: [0, 0], cell_size_m: 0.1, width: 10, height: 10}\n"
      "cameras:\n"
      "  - name: C1\n"
      "    source: files://frames/C1/*.png\n"
      "    calibration: {intrinsics: intr_C1.xml, extrinsics: extr_C1.xml}\n"
      "    background: C1.png\n",
      folder.file("occmap.yaml"));
  ASSERT_EQ(config.cameras.size(), 1u);
  EXPECT_EQ(config.cameras[0].calibration, intrinsics);
  EXPECT_EQ(config.cameras[0].extrinsics, extrinsics);
  EXPECT_EQ(config.cameras[0].world_frame, WorldFrame::kRightHanded);
}

// A calibration without its image size takes the stream's: the rig's camera has the frames' size.
TEST(OpenCvXml, TheImageSizeLeftOutIsTheStreams) {
  const TemporaryFolder folder;
  writeIntrinsics(folder.file("intr.xml"), false);
  folder.write("extr.xml", extrinsicsXml(kRvec, kTvec));
  const cv::Mat grey(270, 480, CV_8UC1, cv::Scalar(120));
  std::filesystem::create_directories(folder / "frames");
  cv::imwrite((folder / "frames" / "000000.png").string(), grey);
  cv::imwrite((folder / "background.png").string(), grey);
  folder.write("site.yaml",
               "map: {origin_m: [-2, 1], cell_size_m: 0.1, width: 40, height: 40}\n"
               "cameras:\n"
               "  - name: C1\n"
               "    source: files://frames/*.png\n"
               "    calibration: {intrinsics: intr.xml, extrinsics: extr.xml}\n"
               "    background: background.png\n");
  const Rig rig = Rig::open(loadConfig(folder / "site.yaml"));
  ASSERT_EQ(rig.cameras().size(), 1u);
  const Camera& camera = *rig.cameras().front().camera;
  EXPECT_EQ(camera.model().width(), 480);
  EXPECT_EQ(camera.model().height(), 270);
  // The calibration frame is the stream: a floor point lands on cv::projectPoints' pixel.
  std::vector<cv::Point2d> expected;
  cv::projectPoints(std::vector<cv::Point3d>{{0.5, 3.0, 0.0}}, kRvec, kTvec, kCameraMatrix,
                    kDistortion, expected);
  const auto pixel = camera.worldToStream({0.5, 3.0, 0.0});
  ASSERT_TRUE(pixel);
  EXPECT_NEAR(pixel->x(), expected[0].x, 1e-6);
  EXPECT_NEAR(pixel->y(), expected[0].y, 1e-6);
}

TEST(OpenCvXml, SlipsAreNamedWithFileLineAndField) {
  const TemporaryFolder folder;
  const fs::path intrinsics = writeIntrinsics(folder.file("intr.xml"), false);
  // The extrinsics without tvec: the extrinsics file is named.
  const fs::path no_tvec =
      folder.write("extr.xml",
                   "<?xml version=\"1.0\"?>\n<opencv_storage>\n<rvec>1 2 3</rvec>\n"
                   "</opencv_storage>\n");
  const InputError missing = errorOf([&] {
    loadCalibration(CalibrationFiles{intrinsics, no_tvec});
  });
  EXPECT_EQ(missing.file(), no_tvec.string());
  EXPECT_EQ(missing.field(), "tvec");
  EXPECT_TRUE(says(missing, "extrinsics file needs rvec and tvec")) << missing.what();

  // A value that is no number, on line 4 of the extrinsics.
  const fs::path bad_value =
      folder.write("extr2.xml",
                   "<?xml version=\"1.0\"?>\n<opencv_storage>\n<rvec>1 2 3</rvec>\n<tvec>1\n"
                   "  nan 3</tvec>\n</opencv_storage>\n");
  const InputError not_finite = errorOf([&] {
    loadCalibration(CalibrationFiles{intrinsics, bad_value});
  });
  EXPECT_EQ(not_finite.line(), 5) << not_finite.what();
  EXPECT_EQ(not_finite.field(), "tvec");
  EXPECT_TRUE(says(not_finite, "finite")) << not_finite.what();

  // The intrinsics without a camera matrix, and not well-formed XML.
  const fs::path no_matrix =
      folder.write("intr2.xml",
                   "<?xml version=\"1.0\"?>\n<opencv_storage>\n<distortion_coefficients "
                   "type_id=\"opencv-matrix\"><rows>1</rows><cols>5</cols><dt>d</dt>\n"
                   "<data>0 0 0 0 0</data></distortion_coefficients>\n</opencv_storage>\n");
  const InputError no_k = errorOf([&] { loadCalibration(CalibrationFiles{no_matrix, bad_value}); });
  EXPECT_EQ(no_k.file(), no_matrix.string());
  EXPECT_EQ(no_k.field(), "camera_matrix");
  const fs::path broken =
      folder.write("c.xml", "<?xml version=\"1.0\"?>\n<opencv_storage>\n<rvec>");
  const InputError syntax = errorOf([&] { loadCalibration(broken); });
  EXPECT_TRUE(says(syntax, "not well-formed XML")) << syntax.what();

  // One side of the image size without the other.
  const fs::path half =
      folder.write("half.yml",
                   "%YAML:1.0\n---\nimage_width: 640\ncamera_matrix: [500, 0, 320, 0, 500, 240, "
                   "0, 0, 1]\ndistortion_coefficients: [0, 0, 0, 0, 0]\nrvec: [0, 0, 0]\n"
                   "tvec: [0, 0, 1]\n");
  const InputError size = errorOf([&] { loadCalibration(half); });
  EXPECT_EQ(size.field(), "image_height");

  // The config: a calibration mapping without its extrinsics, an unknown world frame.
  const std::string head =
      "map: {origin_m: [0, 0], cell_size_m: 0.1, width: 10, height: 10}\n"
      "cameras:\n"
      "  - name: C1\n"
      "    source: files://frames/C1/*.png\n"
      "    background: C1.png\n";
  const InputError one_file = errorOf([&] {
    parseConfig(head + "    calibration: {intrinsics: intr.xml}\n", folder.file("a.yaml"));
  });
  EXPECT_EQ(one_file.field(), "cameras[0].calibration.extrinsics") << one_file.what();
  const InputError frame = errorOf([&] {
    parseConfig(head + "    calibration: c.yml\n    world_frame: mirrored\n",
                folder.file("b.yaml"));
  });
  EXPECT_EQ(frame.line(), 7) << frame.what();
  EXPECT_TRUE(says(frame, "left-handed")) << frame.what();
}

// MultiviewX's extrinsics, made in Unity's left-handed world: every floor point lies at negative
// depth, where cv::projectPoints still gives it its pixel (the annotated feet land there).
TEST(OpenCvXml, LeftHandedWorldIsTheMirroredCamera) {
  const TemporaryFolder folder;
  const fs::path intrinsics = writeIntrinsics(folder.file("intr.xml"), true);
  const auto [left_rvec, left_tvec] = testing::leftHandedExtrinsics(kRvec, kTvec);
  const fs::path extrinsics = folder.write("extr.xml", extrinsicsXml(left_rvec, left_tvec));

  // Read as right-handed, every floor point is behind the camera ...
  const LoadedCalibration right = loadCalibration(CalibrationFiles{intrinsics, extrinsics});
  for (const cv::Point3d& p : floorPoints()) {
    EXPECT_FALSE(right.model->worldToImage({p.x, p.y, p.z})) << p;
  }
  // ... and with world_frame: left-handed each lands where cv::projectPoints puts it.
  const LoadedCalibration left = loadCalibration(CalibrationFiles{intrinsics, extrinsics},
                                                 std::nullopt, WorldFrame::kLeftHanded);
  expectProjectsLikeOpenCv(*left.model, left_rvec, left_tvec);
  // It is the very camera of the right-handed pose, floor point for floor point.
  const LoadedCalibration plain = loadCalibration(
      CalibrationFiles{intrinsics, folder.write("extr_plain.xml", extrinsicsXml(kRvec, kTvec))});
  for (const cv::Point3d& p : floorPoints()) {
    const auto a = left.model->worldToImage({p.x, p.y, 0});
    const auto b = plain.model->worldToImage({p.x, p.y, 0});
    ASSERT_EQ(a.has_value(), b.has_value());
    if (a) {
      EXPECT_LT((a->pixel - b->pixel).norm(), 1e-6);
    }
  }
  // A re-posed left-handed camera keeps its file's frame.
  const auto moved = left.model->withPose(left.model->pose());
  const auto& p = static_cast<const OpenCvCamera&>(*moved).parameters();
  EXPECT_LT((p.rvec - Eigen::Vector3d(left_rvec[0], left_rvec[1], left_rvec[2])).norm(), 1e-9);
  EXPECT_LT((p.tvec - Eigen::Vector3d(left_tvec[0], left_tvec[1], left_tvec[2])).norm(), 1e-9);

  // Tsai's model has no such frame.
  const fs::path tsai = folder.write("tsai.xml", testing::kDownwardXml);
  const InputError error = errorOf([&] {
    loadCalibration(CalibrationFiles{tsai, std::nullopt}, {}, WorldFrame::kLeftHanded);
  });
  EXPECT_TRUE(says(error, "OpenCV calibrations")) << error.what();
}

}  // namespace
}  // namespace occmap
