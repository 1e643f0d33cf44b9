// Calibration files as users bring them: a Tsai (ETISEO XML) or OpenCV (cv::FileStorage YAML) file
// loads into exactly the camera it describes, and a broken one is refused with the file, line and
// field named. The OpenCV loader is checked against OpenCV itself.
#include "config/calibration_file.h"

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <utility>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <unistd.h>

#include "config/input_error.h"
#include "input_error_of.h"
#include "temporary_folder.h"
#include "tsai_xml.h"

namespace occmap {
namespace {

using testing::errorOf;
using testing::says;

namespace fs = std::filesystem;

using testing::TemporaryFolder;

// ----------------------------------------------------------------------------------------------
// Tsai XML

// PETS 2009 View_001's values, laid out over several lines as the EPFL files are. Line numbers:
std::string tsaiXml(const std::string& geometry =
                        "width=\"768\" height=\"576\" ncx=\"7.9500000000e+02\"\n"
                        "            nfx=\"7.5200000000e+02\" dx=\"4.8500000000e-03\"\n"
                        "            dy=\"4.6500000000e-03\" dpx=\"5.1273271277e-03\"\n"
                        "            dpy=\"4.6500000000e-03\"",
                    const std::string& intrinsic =
                        "focal=\"5.5549183034e+00\" kappa1=\"5.1113043639e-03\"\n"
                        "             cx=\"3.2422149053e+02\" cy=\"2.8256650051e+02\" "
                        "sx=\"1.0937855397e+00\"") {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"  // 1
         "\n"                                            // 2
         "<Camera name=\"View_001\">\n"                  // 3
         "  <Geometry " +                                // 4..7
         geometry +
         "/>\n"
         "  <Intrinsic " +  // 8..9
         intrinsic +
         "/>\n"
         "  <Extrinsic tx=\"8.2873214225e+02\" ty=\"-3.1754796051e+03\" tz=\"3.5469298547e+04\"\n"
         "             rx=\"2.0405458695e+00\" ry=\"-8.9337703748e-01\" "
         "rz=\"-4.3056124791e-01\"/>\n"
         "</Camera>\n";
}

TEST(TsaiXml, ValidFileLoadsExactly) {
  const TemporaryFolder folder;
  const TsaiParameters p = loadTsaiXml(folder.write("view.xml", tsaiXml()));
  EXPECT_EQ(p.width, 768);
  EXPECT_EQ(p.height, 576);
  EXPECT_EQ(p.ncx, 795.0);
  EXPECT_EQ(p.nfx, 752.0);
  EXPECT_EQ(p.dx, 4.85e-3);
  EXPECT_EQ(p.dy, 4.65e-3);
  EXPECT_EQ(p.dpx, 5.1273271277e-03);
  EXPECT_EQ(p.dpy, 4.65e-3);
  EXPECT_EQ(p.focal, 5.5549183034);
  EXPECT_EQ(p.kappa1, 5.1113043639e-03);
  EXPECT_EQ(p.cx, 324.22149053);
  EXPECT_EQ(p.cy, 282.56650051);
  EXPECT_EQ(p.sx, 1.0937855397);
  EXPECT_EQ(p.tx, 828.73214225);
  EXPECT_EQ(p.ty, -3175.4796051);
  EXPECT_EQ(p.tz, 35469.298547);
  EXPECT_EQ(p.rx, 2.0405458695);
  EXPECT_EQ(p.ry, -0.89337703748);
  EXPECT_EQ(p.rz, -0.43056124791);
}

TEST(TsaiXml, EffectivePixelSpacingMayBeLeftOut) {
  const TsaiParameters p = parseTsaiXml(
      tsaiXml("width=\"768\" height=\"576\" ncx=\"795\" nfx=\"752\" dx=\"4.85e-3\" dy=\"4.65e-3\""),
      "view.xml");
  EXPECT_DOUBLE_EQ(p.dpx, 4.85e-3 * 795 / 752) << "Willson: dpx = dx * ncx / nfx";
  EXPECT_EQ(p.dpy, 4.65e-3) << "Willson: dpy = dy";
}

TEST(TsaiXml, MissingAttributeNamesElementAttributeAndLine) {
  const InputError error = errorOf([] {
    parseTsaiXml(
        tsaiXml(std::string("width=\"768\" height=\"576\" ncx=\"795\" nfx=\"752\" dx=\"4.85e-3\" "
                            "dy=\"4.65e-3\""),
                "kappa1=\"0\" cx=\"320\" cy=\"240\" sx=\"1\""),
        "cam.xml");
  });
  EXPECT_EQ(error.file(), "cam.xml");
  EXPECT_EQ(error.field(), "Intrinsic.focal");
  EXPECT_EQ(error.line(), 5) << "the line where <Intrinsic> starts";
  EXPECT_EQ(std::string(error.what()).rfind("cam.xml:5: Intrinsic.focal: ", 0), 0u) << error.what();
  EXPECT_TRUE(says(error, "focal length")) << error.what();
  EXPECT_TRUE(says(error, "missing")) << error.what();
}

TEST(TsaiXml, AttributeErrorsPointAtTheAttributesLine) {
  // <Geometry> spans lines 4 to 7; dpy is on line 7 and libxml2 only knows where the tag ends.
  const InputError error = errorOf([] {
    parseTsaiXml(tsaiXml("width=\"768\" height=\"576\" ncx=\"795\"\n nfx=\"752\" dx=\"4.85e-3\"\n"
                         " dpx=\"abc\" dy=\"4.65e-3\"\n dpy=\"4.65e-3\""),
                 "cam.xml");
  });
  EXPECT_EQ(error.field(), "Geometry.dpx");
  EXPECT_EQ(error.line(), 6) << error.what();
  EXPECT_TRUE(says(error, "\"abc\" is not a number")) << error.what();
}

TEST(TsaiXml, NonFiniteValuesAreRefused) {
  for (const std::string value : {"nan", "NaN", "inf", "-inf", "1e400"}) {
    const InputError error = errorOf([&] {
      parseTsaiXml(tsaiXml(std::string("width=\"768\" height=\"576\" ncx=\"795\" nfx=\"752\" "
                                       "dx=\"4.85e-3\" dy=\"4.65e-3\""),
                           "focal=\"5\" kappa1=\"" + value + "\" cx=\"320\" cy=\"240\" sx=\"1\""),
                   "cam.xml");
    });
    EXPECT_EQ(error.field(), "Intrinsic.kappa1") << value;
    EXPECT_EQ(error.line(), 5) << value;
    EXPECT_TRUE(says(error, "finite")) << error.what();
  }
}

TEST(TsaiXml, ZeroOrNegativeScalesAreRefused) {
  const std::string geometry =
      "width=\"768\" height=\"576\" ncx=\"795\" nfx=\"752\" dx=\"4.85e-3\" dy=\"4.65e-3\"";
  const InputError focal = errorOf([&] {
    parseTsaiXml(tsaiXml(geometry, "focal=\"0\" kappa1=\"0\" cx=\"320\" cy=\"240\" sx=\"1\""),
                 "cam.xml");
  });
  EXPECT_EQ(focal.field(), "Intrinsic.focal");
  EXPECT_EQ(focal.line(), 5) << "the line of <Intrinsic>: " << focal.what();
  EXPECT_EQ(std::string(focal.what()).rfind("cam.xml:5: Intrinsic.focal: is 0; ", 0), 0u)
      << focal.what();
  EXPECT_TRUE(says(focal, "must be > 0")) << focal.what();

  const InputError sx = errorOf([&] {
    parseTsaiXml(tsaiXml(geometry, "focal=\"5\" kappa1=\"0\" cx=\"320\" cy=\"240\" sx=\"-1\""),
                 "cam.xml");
  });
  EXPECT_EQ(sx.field(), "Intrinsic.sx");

  const InputError width = errorOf([] {
    parseTsaiXml(
        tsaiXml("width=\"768.5\" height=\"576\" ncx=\"795\" nfx=\"752\" dx=\"4.85e-3\" dy=\"1\""),
        "cam.xml");
  });
  EXPECT_EQ(width.field(), "Geometry.width");
  EXPECT_TRUE(says(width, "whole number of pixels")) << width.what();

  const InputError height = errorOf([] {
    parseTsaiXml(
        tsaiXml("width=\"768\" height=\"0\" ncx=\"795\" nfx=\"752\" dx=\"4.85e-3\" dy=\"1\""),
        "cam.xml");
  });
  EXPECT_EQ(height.field(), "Geometry.height");
}

TEST(TsaiXml, InconsistentEffectivePixelSpacingNamesBothFields) {
  const InputError error = errorOf([] {
    parseTsaiXml(tsaiXml("width=\"768\" height=\"576\" ncx=\"795\" nfx=\"752\" dx=\"4.85e-3\" "
                         "dy=\"4.65e-3\" dpx=\"4.85e-3\""),
                 "cam.xml");
  });
  EXPECT_EQ(error.field(), "Geometry.dpx");
  EXPECT_EQ(error.line(), 4);
  EXPECT_TRUE(says(error, "Geometry.dx * Geometry.ncx / Geometry.nfx")) << error.what();

  const InputError dpy = errorOf([] {
    parseTsaiXml(tsaiXml("width=\"768\" height=\"576\" ncx=\"795\" nfx=\"752\" dx=\"4.85e-3\" "
                         "dy=\"4.65e-3\" dpy=\"4.7e-3\""),
                 "cam.xml");
  });
  EXPECT_EQ(dpy.field(), "Geometry.dpy");
  EXPECT_TRUE(says(dpy, "Geometry.dy")) << dpy.what();

  // Rounded to 11 significant digits, as the PETS files write it: accepted.
  EXPECT_NO_THROW(parseTsaiXml(tsaiXml(), "cam.xml"));
}

TEST(TsaiXml, MalformedXmlGivesLibxml2sLineAndMessage) {
  const InputError error = errorOf([] {
    parseTsaiXml(
        "<?xml version=\"1.0\"?>\n<Camera>\n  <Geometry width=\"1\" width=\"2\"/>\n</Camera>\n",
        "cam.xml");
  });
  EXPECT_EQ(error.line(), 3);
  EXPECT_TRUE(says(error, "not well-formed XML")) << error.what();
  EXPECT_TRUE(says(error, "redefined")) << error.what();

  const InputError truncated = errorOf([] {
    parseTsaiXml("<?xml version=\"1.0\"?>\n<Camera>\n  <Geometry width=\"1\"", "cam.xml");
  });
  EXPECT_GE(truncated.line(), 3) << truncated.what();
  EXPECT_EQ(std::string(truncated.what()).rfind("cam.xml:", 0), 0u) << truncated.what();
}

TEST(TsaiXml, MissingOrWrongElementsAreNamed) {
  const InputError missing = errorOf([] {
    parseTsaiXml("<?xml version=\"1.0\"?>\n<Camera>\n  <Geometry/>\n  <Intrinsic/>\n</Camera>\n",
                 "cam.xml");
  });
  EXPECT_EQ(missing.field(), "Extrinsic");
  EXPECT_EQ(missing.line(), 2);

  const InputError twice = errorOf([] {
    std::string text = tsaiXml();
    text.insert(text.find("</Camera>"), "  <Intrinsic focal=\"1\"/>\n");
    parseTsaiXml(text, "cam.xml");
  });
  EXPECT_EQ(twice.field(), "Intrinsic");
  EXPECT_TRUE(says(twice, "appears twice (lines 8 and 12)")) << twice.what();

  const InputError root = errorOf([] {
    parseTsaiXml("<?xml version=\"1.0\"?>\n<opencv_storage>\n</opencv_storage>\n", "cam.xml");
  });
  EXPECT_EQ(root.line(), 2);
  EXPECT_TRUE(says(root, "this is an OpenCV calibration (cv::FileStorage XML)")) << root.what();
}

TEST(TsaiXml, NeverFetchesExternalEntities) {
  const InputError error = errorOf([] {
    parseTsaiXml(
        "<?xml version=\"1.0\"?>\n<!DOCTYPE Camera [<!ENTITY e SYSTEM \"file:///etc/hostname\">]>\n"
        "<Camera name=\"&e;\"/>\n",
        "cam.xml");
  });
  EXPECT_TRUE(says(error, "external entity")) << error.what();
}

// ----------------------------------------------------------------------------------------------
// OpenCV YAML

struct OpenCvFile {
  int width = 640;
  int height = 480;
  cv::Mat camera_matrix = (cv::Mat_<double>(3, 3) << 812.5, 0, 331.25, 0, 808.75, 236.5, 0, 0, 1);
  cv::Mat distortion = (cv::Mat_<double>(1, 5) << -0.28, 0.07, 1e-3, -5e-4, 0.0);
  cv::Mat rvec = (cv::Mat_<double>(3, 1) << 2.1, -0.3, 0.25);
  cv::Mat tvec = (cv::Mat_<double>(3, 1) << 0.4, 1.3, 3.2);
  std::string leave_out;  // a key not to write

  // Written by cv::FileStorage itself, so that the test reads the real format.
  fs::path write(const fs::path& file) const {
    cv::FileStorage storage(file.string(), cv::FileStorage::WRITE | cv::FileStorage::FORMAT_YAML);
    auto put = [&](const std::string& key, const auto& value) {
      if (key != leave_out) storage << key << value;
    };
    put("image_width", width);
    put("image_height", height);
    put("camera_matrix", camera_matrix);
    put("distortion_coefficients", distortion);
    put("rvec", rvec);
    put("tvec", tvec);
    return file;
  }
};

TEST(OpenCvYaml, LoadsWhatCvFileStorageWrites) {
  const TemporaryFolder folder;
  const OpenCvFile file;
  const OpenCvParameters p = loadOpenCvYaml(file.write(folder.file("c0.yml")));
  EXPECT_EQ(p.width, 640);
  EXPECT_EQ(p.height, 480);
  EXPECT_EQ(p.fx, 812.5);
  EXPECT_EQ(p.fy, 808.75);
  EXPECT_EQ(p.cx, 331.25);
  EXPECT_EQ(p.cy, 236.5);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(p.distortion[static_cast<std::size_t>(i)], file.distortion.at<double>(i)) << i;
  }
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(p.rvec[i], file.rvec.at<double>(i)) << i;
    EXPECT_EQ(p.tvec[i], file.tvec.at<double>(i)) << i;
  }
}

// What occmap writes of a model (a re-posed camera's calibration, core/repose.h) reads back the
// same, bit for bit, in both kinds; OpenCV's own reader takes the YAML too.
TEST(CalibrationText, ReadsBackExactlyInBothKinds) {
  const TemporaryFolder folder;
  const OpenCvFile file;
  const OpenCvParameters p = loadOpenCvYaml(file.write(folder.file("c0.yml")));
  const auto yaml = calibrationText(OpenCvCamera(p), "c0");
  ASSERT_TRUE(yaml);
  EXPECT_EQ(yaml->extension, ".yaml");
  const OpenCvParameters again = parseOpenCvYaml(yaml->text, "written.yaml");
  EXPECT_EQ(again.width, p.width);
  EXPECT_EQ(again.height, p.height);
  EXPECT_EQ(again.fx, p.fx);
  EXPECT_EQ(again.fy, p.fy);
  EXPECT_EQ(again.cx, p.cx);
  EXPECT_EQ(again.cy, p.cy);
  EXPECT_EQ(again.distortion, p.distortion);
  EXPECT_EQ(again.rvec, p.rvec);
  EXPECT_EQ(again.tvec, p.tvec);
  cv::FileStorage storage(yaml->text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
  cv::Mat rvec;
  storage["rvec"] >> rvec;
  ASSERT_EQ(rvec.total(), 3u);
  EXPECT_EQ(rvec.at<double>(2), p.rvec.z());

  const TsaiParameters tsai = parseTsaiXml(testing::kDownwardXml, "down.xml");
  const auto xml = calibrationText(TsaiCamera(tsai), "c1");
  ASSERT_TRUE(xml);
  EXPECT_EQ(xml->extension, ".xml");
  const TsaiParameters tsai_again = parseTsaiXml(xml->text, "written.xml");
  EXPECT_EQ(tsai_again.rx, tsai.rx);
  EXPECT_EQ(tsai_again.tz, tsai.tz);
  EXPECT_EQ(tsai_again.focal, tsai.focal);
  EXPECT_EQ(tsai_again.kappa1, tsai.kappa1);
}

// The farthest, in pixels, that `camera` images points from where cv::projectPoints images them
// with `file`'s parameters: 2000 points in front of the camera, at normalised radii below `limit`
// (inside the model's valid radius), 0.5 to 20 units deep. Infinite when one has no image.
double farthestFromCvProjectPoints(const OpenCvCamera& camera, const OpenCvFile& file, double limit,
                                   std::mt19937_64& random) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<cv::Point3d> world;
  std::vector<Eigen::Vector2d> ours;
  const Eigen::Matrix3d rotation = camera.pose().rotation;
  const Eigen::Vector3d translation = camera.pose().translation;
  for (int i = 0; i < 2000; ++i) {
    const double radius = limit * std::sqrt(unit(random)) * 0.999;
    const double angle = 2 * std::numbers::pi * unit(random);
    const double depth = 0.5 + 19.5 * unit(random);
    const Eigen::Vector3d in_camera(radius * std::cos(angle) * depth,
                                    radius * std::sin(angle) * depth, depth);
    const Eigen::Vector3d w = rotation.transpose() * (in_camera - translation);
    const std::optional<ImagePoint> image = camera.worldToImage(w);
    if (!image) {
      ADD_FAILURE() << "radius " << radius << " is inside maxRadius " << camera.maxRadius();
      return std::numeric_limits<double>::infinity();
    }
    world.emplace_back(w.x(), w.y(), w.z());
    ours.push_back(image->pixel);
  }
  std::vector<cv::Point2d> theirs;
  cv::projectPoints(world, file.rvec, file.tvec, file.camera_matrix, file.distortion, theirs);
  double worst = 0;
  for (std::size_t i = 0; i < world.size(); ++i) {
    worst = std::max(worst, std::hypot(ours[i].x() - theirs[i].x, ours[i].y() - theirs[i].y));
  }
  return worst;
}

// What the loader builds projects as OpenCV does, on points anywhere inside the model's valid
// radius.
TEST(OpenCvYaml, ProjectsLikeCvProjectPoints) {
  const TemporaryFolder folder;
  // The realistic lens of the brief (k3 = 0: monotonic for ever) and one with a k3 that makes the
  // polynomial turn, so that maxRadius() is finite.
  const std::vector<std::array<double, 5>> lenses = {{-0.28, 0.07, 1e-3, -5e-4, 0.0},
                                                     {-0.28, 0.07, 1e-3, -5e-4, -0.02}};
  std::mt19937_64 random(20240611);
  for (const auto& lens : lenses) {
    OpenCvFile file;
    file.distortion = (cv::Mat_<double>(1, 5) << lens[0], lens[1], lens[2], lens[3], lens[4]);
    const LoadedCalibration loaded = loadCalibration(file.write(folder.file("lens.yml")));
    ASSERT_EQ(loaded.kind, "opencv");
    const auto& camera = dynamic_cast<const OpenCvCamera&>(*loaded.model);
    const double limit = std::min(camera.maxRadius(), 1.5);  // 1.5: ~56 degrees off axis
    if (lens[4] != 0.0) {
      EXPECT_TRUE(std::isfinite(camera.maxRadius()));
    } else {
      EXPECT_TRUE(std::isinf(camera.maxRadius()));
    }

    const double worst = farthestFromCvProjectPoints(camera, file, limit, random);
    EXPECT_LT(worst, 1e-6) << "pixels apart from cv::projectPoints, k3 = " << lens[4];
  }
}

// A lens whose radial polynomial turns (k3 < 0: maxRadius() about 1.25, some 51 degrees off axis)
// on a camera 3.2 units above the floor looking straight down, so that every ray inside that
// radius meets the floor in front of the camera.
OpenCvFile turningLensLookingDown() {
  OpenCvFile file;
  file.distortion = (cv::Mat_<double>(1, 5) << -0.28, 0.07, 1e-3, -5e-4, -0.02);
  file.rvec = (cv::Mat_<double>(3, 1) << std::numbers::pi, 0, 0);
  return file;
}

// Past the radius where the polynomial stops increasing, cv::projectPoints folds points back into
// the picture, where they would carve cells they are not in. Our model gives no result there, in
// both directions, and exactly at that radius, not somewhere inside it.
TEST(OpenCvYaml, RefusesPastTheMonotonicRadiusInBothDirections) {
  const TemporaryFolder folder;
  const OpenCvFile file = turningLensLookingDown();
  const LoadedCalibration loaded = loadCalibration(file.write(folder.file("lens.yml")));
  const auto& camera = dynamic_cast<const OpenCvCamera&>(*loaded.model);
  const double max_radius = camera.maxRadius();
  ASSERT_TRUE(std::isfinite(max_radius));
  const Eigen::Matrix3d rotation = camera.pose().rotation;
  const Eigen::Vector3d translation = camera.pose().translation;
  const auto& d = camera.parameters().distortion;
  const double s = max_radius * max_radius;
  // The normalised image radius of a point at max_radius (radially; tangential terms add < 1 %).
  const double image_radius = max_radius * (1.0 + s * (d[0] + s * (d[1] + s * d[4])));
  const double fx = camera.parameters().fx, fy = camera.parameters().fy;
  const double cx = camera.parameters().cx, cy = camera.parameters().cy;
  for (int k = 0; k < 36; ++k) {
    const double angle = 2 * std::numbers::pi * k / 36;
    const auto worldAt = [&](double radius) {
      const double depth = 3.2;
      const Eigen::Vector3d in_camera(radius * std::cos(angle) * depth,
                                      radius * std::sin(angle) * depth, depth);
      return Eigen::Vector3d(rotation.transpose() * (in_camera - translation));
    };
    EXPECT_TRUE(camera.worldToImage(worldAt(0.999 * max_radius))) << "angle " << angle;
    for (const double past : {1.001, 1.3, 2.0}) {
      EXPECT_FALSE(camera.worldToImage(worldAt(past * max_radius)))
          << past << " x maxRadius, angle " << angle << ": a folded-back point got a pixel";
    }
    // OpenCV does give such a point a pixel, folded back inside the image of maxRadius.
    std::vector<cv::Point2d> folded;
    const Eigen::Vector3d w = worldAt(1.3 * max_radius);
    cv::projectPoints(std::vector<cv::Point3d>{{w.x(), w.y(), w.z()}}, file.rvec, file.tvec,
                      file.camera_matrix, file.distortion, folded);
    EXPECT_LT(std::hypot((folded[0].x - cx) / fx, (folded[0].y - cy) / fy), image_radius);

    const auto pixelAt = [&](double radius) {
      return Eigen::Vector2d(cx + fx * radius * std::cos(angle),
                             cy + fy * radius * std::sin(angle));
    };
    EXPECT_TRUE(camera.imageToPlane(pixelAt(0.95 * image_radius), 0.0)) << "angle " << angle;
    for (const double past : {1.05, 1.5, 3.0}) {
      EXPECT_FALSE(camera.imageToPlane(pixelAt(past * image_radius), 0.0))
          << past << " x the image of maxRadius, angle " << angle << ": a pixel no ray reaches "
          << "met the floor";
      EXPECT_FALSE(camera.imageToRay(pixelAt(past * image_radius))) << past;
    }
  }
}

// A pixel's floor point images back into that pixel, everywhere in the picture and, for the lens
// that turns, out to just inside the image of its monotonic radius.
TEST(OpenCvYaml, ImageToPlaneToImageRoundTrips) {
  const TemporaryFolder folder;
  OpenCvFile steady = turningLensLookingDown();
  steady.distortion.at<double>(4) = 0.0;  // k3 = 0: increasing for ever
  std::mt19937_64 random(20240612);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const OpenCvFile& file : {steady, turningLensLookingDown()}) {
    const LoadedCalibration loaded = loadCalibration(file.write(folder.file("lens.yml")));
    const auto& camera = dynamic_cast<const OpenCvCamera&>(*loaded.model);
    const auto& p = camera.parameters();
    std::vector<Eigen::Vector2d> pixels;
    pixels.reserve(2500);
    for (int i = 0; i < 2000; ++i) {
      pixels.emplace_back(-0.5 + p.width * unit(random), -0.5 + p.height * unit(random));
    }
    if (std::isfinite(camera.maxRadius())) {
      const double s = camera.maxRadius() * camera.maxRadius();
      const auto& d = p.distortion;
      const double image_radius = camera.maxRadius() * (1.0 + s * (d[0] + s * (d[1] + s * d[4])));
      for (int i = 0; i < 500; ++i) {
        const double radius = 0.95 * image_radius * std::sqrt(unit(random));
        const double angle = 2 * std::numbers::pi * unit(random);
        pixels.emplace_back(p.cx + p.fx * radius * std::cos(angle),
                            p.cy + p.fy * radius * std::sin(angle));
      }
    }
    double worst = 0;
    for (const Eigen::Vector2d& pixel : pixels) {
      const std::optional<PlanePoint> floor = camera.imageToPlane(pixel, 0.0);
      ASSERT_TRUE(floor) << "pixel " << pixel.transpose()
                         << " has no floor point, k3 = " << p.distortion[4];
      EXPECT_NEAR(floor->world.z(), 0.0, 1e-12);
      const std::optional<ImagePoint> back = camera.worldToImage(floor->world);
      ASSERT_TRUE(back) << "the floor point of pixel " << pixel.transpose() << " has no image";
      EXPECT_NEAR(back->depth, floor->depth, 1e-9);
      worst = std::max(worst, (back->pixel - pixel).norm());
    }
    EXPECT_LT(worst, 1e-6) << "pixels from where they started, k3 = " << p.distortion[4];
    std::printf("image -> floor -> image, k3 = %g: worst %.2g px over %zu pixels\n",
                p.distortion[4], worst, pixels.size());
  }
}

InputError openCvError(const OpenCvFile& file) {
  const TemporaryFolder folder;
  const fs::path path = file.write(folder.file("bad.yml"));
  InputError error = errorOf([&] { loadOpenCvYaml(path); });
  EXPECT_EQ(error.file(), path.string());
  // "FILE: FIELD: ..." when the whole file is meant (a missing key), else "FILE:LINE: FIELD: ...".
  const std::string where =
      path.string() + (error.line() > 0 ? ":" + std::to_string(error.line()) : "") + ": ";
  EXPECT_EQ(std::string(error.what()).rfind(where + error.field() + ": ", 0), 0u) << error.what();
  return error;
}

TEST(OpenCvYaml, MissingKeyIsNamed) {
  for (const std::string key :
       {"image_width", "camera_matrix", "distortion_coefficients", "tvec"}) {
    OpenCvFile file;
    file.leave_out = key;
    const InputError error = openCvError(file);
    EXPECT_EQ(error.field(), key);
    EXPECT_EQ(error.line(), 0) << "a key that is absent is in no line";
    EXPECT_TRUE(says(error, "is missing")) << error.what();
  }
}

TEST(OpenCvYaml, NonFiniteValuesAreRefused) {
  OpenCvFile file;
  file.camera_matrix.at<double>(0, 2) = std::numeric_limits<double>::quiet_NaN();
  const InputError matrix = openCvError(file);
  EXPECT_EQ(matrix.field(), "camera_matrix");
  EXPECT_TRUE(says(matrix, "value 2 is")) << matrix.what();
  EXPECT_TRUE(says(matrix, "finite")) << matrix.what();
  // cv::FileStorage writes "image_width", "image_height", "camera_matrix: !!opencv-matrix",
  // rows, cols, dt, then "data: [ 812.5, 0., .Nan," on line 9 (after %YAML:1.0 and ---).
  EXPECT_EQ(matrix.line(), 9) << "the line of the value: " << matrix.what();

  OpenCvFile far;
  far.tvec.at<double>(2) = std::numeric_limits<double>::infinity();
  const InputError tvec = openCvError(far);
  EXPECT_EQ(tvec.field(), "tvec");
  EXPECT_TRUE(says(tvec, "finite")) << tvec.what();
}

// OpenCV's model lengths: 4 and 5 (the usual), 8 (rational), 12 (thin prism), 14 (tilted sensor,
// refused unless its two terms are zero); any other count is refused, naming the count.
TEST(OpenCvYaml, OpenCvsModelLengths) {
  OpenCvFile tilted;
  tilted.distortion =
      (cv::Mat_<double>(14, 1) << -0.28, 0.07, 1e-3, -5e-4, 0.02, 0, 0, 0, 0, 0, 0, 0, 0.01, 0.0);
  const InputError tilt = openCvError(tilted);
  EXPECT_EQ(tilt.field(), "distortion_coefficients");
  EXPECT_TRUE(says(tilt, "CALIB_TILTED_MODEL")) << tilt.what();

  for (const int count : {3, 6, 13}) {
    OpenCvFile odd;
    odd.distortion = cv::Mat::zeros(1, count, CV_64F);
    const InputError error = openCvError(odd);
    EXPECT_EQ(error.field(), "distortion_coefficients");
    EXPECT_TRUE(says(error, std::to_string(count) + " coefficients")) << error.what();
  }

  const TemporaryFolder folder;
  OpenCvFile level_sensor;  // 14 with taux = tauy = 0: the thin prism model exactly
  level_sensor.distortion = (cv::Mat_<double>(14, 1) << -0.28, 0.07, 1e-3, -5e-4, 0.02, 0.1, 0.01,
                             0.001, 1e-4, 2e-4, 3e-4, 4e-4, 0, 0);
  const OpenCvParameters p = loadOpenCvYaml(level_sensor.write(folder.file("z.yml")));
  for (int i = 0; i < 12; ++i) {
    EXPECT_EQ(p.distortion[static_cast<std::size_t>(i)], level_sensor.distortion.at<double>(i));
  }

  OpenCvFile four;
  four.distortion = (cv::Mat_<double>(4, 1) << -0.28, 0.07, 1e-3, -5e-4);
  const OpenCvParameters p4 = loadOpenCvYaml(four.write(folder.file("four.yml")));
  EXPECT_EQ(p4.distortion[3], -5e-4);
  EXPECT_EQ(p4.distortion[4], 0.0) << "4 coefficients: k3 = 0";
}

// A wide lens calibrated with CALIB_RATIONAL_MODEL and one with CALIB_THIN_PRISM_MODEL project as
// cv::projectPoints does, every pixel's floor point images back into it, and what occmap writes of
// them (8 and 12 coefficients) reads back bit for bit.
TEST(OpenCvYaml, RationalAndThinPrismLensesAreOpenCvs) {
  const TemporaryFolder folder;
  const std::vector<std::vector<double>> lenses = {
      {0.58, -0.13, 1e-3, -5e-4, -0.009, 0.93, 0.05, -0.03},
      {-0.28, 0.07, 1e-3, -5e-4, 0.0, 0.0, 0.0, 0.0, 1e-3, -2e-4, 5e-4, 1e-4}};
  std::mt19937_64 random(20261207);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const std::vector<double>& lens : lenses) {
    OpenCvFile file = turningLensLookingDown();
    file.distortion = cv::Mat(lens, true).reshape(1, 1);
    const LoadedCalibration loaded = loadCalibration(file.write(folder.file("lens.yml")));
    const auto& camera = dynamic_cast<const OpenCvCamera&>(*loaded.model);
    const std::string which = std::to_string(lens.size()) + " coefficients";

    const double limit = std::min(camera.maxRadius(), 1.2);
    const double worst = farthestFromCvProjectPoints(camera, file, limit, random);
    EXPECT_LT(worst, 1e-6) << which << ": pixels apart from cv::projectPoints";

    double worst_back = 0;
    const auto& p = camera.parameters();
    for (int i = 0; i < 2000; ++i) {
      const Eigen::Vector2d pixel(-0.5 + p.width * unit(random), -0.5 + p.height * unit(random));
      const std::optional<PlanePoint> floor = camera.imageToPlane(pixel, 0.0);
      ASSERT_TRUE(floor) << which << ": pixel " << pixel.transpose() << " has no floor point";
      const std::optional<ImagePoint> back = camera.worldToImage(floor->world);
      ASSERT_TRUE(back) << which;
      worst_back = std::max(worst_back, (back->pixel - pixel).norm());
    }
    EXPECT_LT(worst_back, 1e-6) << which << ": image -> floor -> image";

    const auto text = calibrationText(camera, "c0");
    ASSERT_TRUE(text);
    EXPECT_EQ(parseOpenCvYaml(text->text, "written.yaml").distortion, p.distortion) << which;
    cv::FileStorage theirs_again(text->text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
    cv::Mat written;
    theirs_again["distortion_coefficients"] >> written;
    EXPECT_EQ(written.total(), lens.size())
        << which << ": written as OpenCV's model of that length";
  }
}

// A zero (or negative) focal length would put every pixel's ray along the axis: refused, naming
// the camera matrix's line (cv::FileStorage writes it on line 5, after image_width and _height).
TEST(OpenCvYaml, ZeroFocalLengthIsRefused) {
  for (const auto& [fx, fy] :
       {std::pair{0.0, 808.75}, std::pair{812.5, 0.0}, std::pair{-812.5, 808.75}}) {
    OpenCvFile file;
    file.camera_matrix.at<double>(0, 0) = fx;
    file.camera_matrix.at<double>(1, 1) = fy;
    const InputError error = openCvError(file);
    EXPECT_EQ(error.field(), "camera_matrix") << error.what();
    EXPECT_EQ(error.line(), 5) << error.what();
    EXPECT_TRUE(says(error, "both focal lengths (in pixels) must be > 0")) << error.what();
  }
}

TEST(OpenCvYaml, SkewAndNonIntrinsicMatricesAreRefused) {
  OpenCvFile skewed;
  skewed.camera_matrix.at<double>(0, 1) = 0.5;
  const InputError skew = openCvError(skewed);
  EXPECT_EQ(skew.field(), "camera_matrix");
  EXPECT_TRUE(says(skew, "skew")) << skew.what();
  EXPECT_TRUE(says(skew, "cv::projectPoints ignores skew")) << skew.what();

  OpenCvFile scaled;
  scaled.camera_matrix.at<double>(2, 2) = 2.0;
  EXPECT_TRUE(says(openCvError(scaled), "K(2,2) = 2"));

  OpenCvFile lower;
  lower.camera_matrix.at<double>(2, 0) = 1e-3;
  EXPECT_TRUE(says(openCvError(lower), "K(2,0)"));

  OpenCvFile small;
  small.camera_matrix = cv::Mat::eye(2, 2, CV_64F);
  EXPECT_TRUE(says(openCvError(small), "3x3"));

  OpenCvFile rvec;
  rvec.rvec = (cv::Mat_<double>(1, 4) << 1, 2, 3, 4);
  EXPECT_EQ(openCvError(rvec).field(), "rvec");
}

TEST(OpenCvYaml, WrongTypesAndSyntaxErrors) {
  const InputError width =
      errorOf([] { parseOpenCvYaml("%YAML:1.0\n---\nimage_width: 640.5\n", "c.yml"); });
  EXPECT_EQ(width.field(), "image_width");
  EXPECT_TRUE(says(width, "whole number")) << width.what();

  const InputError syntax = errorOf(
      [] { parseOpenCvYaml("%YAML:1.0\n---\nimage_width: 640\n  image_height: 480\n", "c.yml"); });
  EXPECT_EQ(syntax.line(), 4) << syntax.what();
  EXPECT_TRUE(says(syntax, "not valid YAML")) << syntax.what();

  // Without the %YAML line (hand-written), lines are the file's own.
  const InputError shifted =
      errorOf([] { parseOpenCvYaml("image_width: 640\n  image_height: 480\n", "c.yaml"); });
  EXPECT_EQ(shifted.line(), 2) << shifted.what();

  const InputError list = errorOf([] { parseOpenCvYaml("%YAML:1.0\n- 1\n- 2\n", "c.yml"); });
  EXPECT_TRUE(says(list, "top level must be a mapping")) << list.what();

  const InputError empty = errorOf([] { parseOpenCvYaml("\n\n", "c.yml"); });
  EXPECT_TRUE(says(empty, "is empty")) << empty.what();
}

TEST(OpenCvYaml, HandWrittenYamlWithoutDirectiveLoads) {
  const OpenCvParameters p = parseOpenCvYaml(
      "image_width: 720\nimage_height: 576\n"
      "camera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n"
      "  data: [800, 0, 360, 0, 800, 288, 0, 0, 1]\n"
      "distortion_coefficients: [-0.1, 0.01, 0, 0, 0]\n"
      "rvec: [0.1, 0.2, 0.3]\ntvec: [1, 2, 3]\n",
      "c.yaml");
  EXPECT_EQ(p.width, 720);
  EXPECT_EQ(p.fx, 800);
  EXPECT_EQ(p.distortion[0], -0.1);
  EXPECT_EQ(p.tvec.z(), 3);
}

// ----------------------------------------------------------------------------------------------
// Telling the kinds apart

TEST(LoadCalibration, PicksTheLoaderByContentAndTheUnitsByKind) {
  const TemporaryFolder folder;
  const LoadedCalibration tsai = loadCalibration(folder.write("c0.cal", "\n  " + tsaiXml()));
  EXPECT_EQ(tsai.kind, "tsai");
  EXPECT_EQ(tsai.units, LengthUnit::kMillimetre);
  ASSERT_NE(dynamic_cast<const TsaiCamera*>(tsai.model.get()), nullptr);
  EXPECT_EQ(tsai.model->width(), 768);

  const LoadedCalibration opencv = loadCalibration(OpenCvFile{}.write(folder.file("c1.yml")));
  EXPECT_EQ(opencv.kind, "opencv");
  EXPECT_EQ(opencv.units, LengthUnit::kMetre);
  ASSERT_NE(dynamic_cast<const OpenCvCamera*>(opencv.model.get()), nullptr);

  // By content, whatever the name says; a declared unit wins over the kind's default.
  fs::copy_file(folder.file("c1.yml"), folder.file("c1.calibration"));
  const LoadedCalibration renamed =
      loadCalibration(folder.file("c1.calibration"), LengthUnit::kMillimetre);
  EXPECT_EQ(renamed.kind, "opencv");
  EXPECT_EQ(renamed.units, LengthUnit::kMillimetre);

  // A .yaml name is enough for hand-written YAML without the %YAML line.
  const LoadedCalibration plain = loadCalibration(folder.write(
      "c2.yaml",
      "image_width: 720\nimage_height: 576\ncamera_matrix: [800, 0, 360, 0, 800, 288, 0, 0, 1]\n"
      "distortion_coefficients: [0, 0, 0, 0]\nrvec: [0, 0, 0]\ntvec: [0, 0, 3]\n"));
  EXPECT_EQ(plain.kind, "opencv");

  const InputError unknown =
      errorOf([&] { loadCalibration(folder.write("c3.txt", "f = 5\nkappa = 0\n")); });
  EXPECT_TRUE(says(unknown, "neither a Tsai calibration")) << unknown.what();

  const InputError empty = errorOf([&] { loadCalibration(folder.write("c4.xml", "  \n")); });
  EXPECT_TRUE(says(empty, "is empty")) << empty.what();
}

TEST(LoadCalibration, MissingFileSaysWhy) {
  const TemporaryFolder folder;
  const fs::path file = folder.file("absent.xml");
  const InputError error = errorOf([&] { loadCalibration(file); });
  EXPECT_EQ(error.file(), file.string());
  EXPECT_EQ(error.line(), 0);
  EXPECT_EQ(std::string(error.what()),
            file.string() + ": cannot read calibration file: No such file or directory");
}

}  // namespace
}  // namespace occmap
