// Calibration from pictures of a board: a known camera's pictures of a ChArUco board and of a
// chessboard, rendered here, give back its focal lengths within 0.5 % and its principal point
// within 2 px (issue 15's targets); too few or too central pictures and bad SPECs are refused with
// a message that says what to do; and `occmap calibrate intrinsics` writes a file occmap reads.
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/aruco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calibrate/board.h"
#include "calibrate/intrinsics.h"
#include "command_runner.h"
#include "config/calibration_file.h"

namespace occmap {
namespace {

using testing::runCommand;
using testing::TemporaryFolder;

const std::string kOccmap = OCCMAP_BINARY_DIR "/tools/occmap";
constexpr const char* kCharuco = "charuco:7x5:0.04:0.03:DICT_4X4_50";
constexpr const char* kChessboard = "chessboard:9x6:0.025";

// OpenCV's detectors and calibration run in this process on the calling thread alone: the test is
// SINGLE_THREADED (its rendering would take minutes under ThreadSanitizer, finding nothing).
[[maybe_unused]] const bool kOpenCvOnOneThread = [] {
  cv::setNumThreads(0);
  return true;
}();

// The camera the pictures are taken with: 640x480, the principal point a few pixels off-centre,
// OpenCV's 5-coefficient distortion with a strong barrel (k1 = -0.2).
struct TrueCamera {
  cv::Size size{640, 480};
  cv::Matx33d matrix{600.0, 0.0, 323.5, 0.0, 598.0, 236.0, 0.0, 0.0, 1.0};
  cv::Vec<double, 5> distortion{-0.2, 0.05, 0.001, -0.0005, 0.0};
};

// Where the board is: its centre at distance `depth_m` on the ray of pixel (u, v), turned by
// `tilt_x` and `tilt_y` (degrees, about the board's own axes) and rolled by `roll` in its plane.
struct Pose {
  double u, v, depth_m, tilt_x, tilt_y, roll;
};

// Thirteen pictures: the board centred on each cell of a 3 x 3 grid over the image, tilted
// 20 to 35 degrees each way, and four more near the centre, tilted harder or closer.
const std::vector<Pose> kPoses = {
    {165, 125, 0.60, 25, -30, 10},   {320, 120, 0.60, 30, 0, -5},     {475, 125, 0.60, 25, 30, -10},
    {160, 240, 0.60, 0, -35, 5},     {320, 240, 0.55, 0, 0, 0},       {480, 240, 0.60, 5, 35, -5},
    {165, 355, 0.60, -25, -30, -10}, {320, 360, 0.60, -30, 5, 5},     {475, 355, 0.60, -25, 30, 10},
    {320, 240, 0.50, 35, 10, 20},    {320, 240, 0.50, -10, -35, -20}, {300, 230, 0.45, 20, 20, 45},
    {340, 250, 0.70, -20, 25, -30},
};

cv::Matx33d rotation(double degrees, int axis) {
  const double a = degrees * std::numbers::pi / 180.0;
  const double c = std::cos(a), s = std::sin(a);
  if (axis == 0) return {1, 0, 0, 0, c, -s, 0, s, c};
  if (axis == 1) return {c, 0, s, 0, 1, 0, -s, 0, c};
  return {c, -s, 0, s, c, 0, 0, 0, 1};
}

// Renders the board's printed picture as the true camera sees it at a pose. Each pixel is the mean
// of 4 x 4 samples; each sample's ray comes from undistorting its position (once for all
// pictures), meets the board's plane, and reads the picture bilinearly. Then a little noise.
class Renderer {
 public:
  static constexpr int kSamples = 4;
  static constexpr double kPictureMetresPerPixel = 0.0002;  // 5000 pixels per metre

  Renderer() {
    std::vector<cv::Point2f> positions;
    for (int v = 0; v < camera_.size.height * kSamples; ++v) {
      for (int u = 0; u < camera_.size.width * kSamples; ++u) {
        positions.emplace_back(static_cast<float>((u + 0.5) / kSamples - 0.5),
                               static_cast<float>((v + 0.5) / kSamples - 0.5));
      }
    }
    cv::undistortPoints(
        positions, rays_, camera_.matrix, camera_.distortion, cv::noArray(), cv::noArray(),
        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-6));
  }

  const TrueCamera& camera() const { return camera_; }

  // The largest distance (pixels) between a sample's position and its ray projected again: the
  // renderer's own accuracy.
  double largestRayError() const {
    std::vector<cv::Point3f> points;
    std::vector<cv::Point2f> expected;
    const int width = camera_.size.width * kSamples;
    for (std::size_t i = 0; i < rays_.size(); i += 997) {
      points.emplace_back(rays_[i].x, rays_[i].y, 1.0f);
      const int u = static_cast<int>(i) % width, v = static_cast<int>(i) / width;
      expected.emplace_back(static_cast<float>((u + 0.5) / kSamples - 0.5),
                            static_cast<float>((v + 0.5) / kSamples - 0.5));
    }
    std::vector<cv::Point2f> projected;
    cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), camera_.matrix,
                      camera_.distortion, projected);
    double largest = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      largest = std::max(largest, cv::norm(projected[i] - expected[i]));
    }
    return largest;
  }

  cv::Mat render(const cv::Mat& picture, const Pose& pose, unsigned seed) const {
    const cv::Matx33d r =
        rotation(pose.roll, 2) * rotation(pose.tilt_y, 1) * rotation(pose.tilt_x, 0);
    const cv::Vec3d centre((pose.u - camera_.matrix(0, 2)) / camera_.matrix(0, 0) * pose.depth_m,
                           (pose.v - camera_.matrix(1, 2)) / camera_.matrix(1, 1) * pose.depth_m,
                           pose.depth_m);
    // Camera point = R (x, y, 0) + centre, with (x, y) in metres from the picture's centre: the
    // homography [r1 r2 centre] from the board's plane to rays, and its inverse from rays to it.
    const cv::Matx33d plane_to_ray(r(0, 0), r(0, 1), centre[0], r(1, 0), r(1, 1), centre[1],
                                   r(2, 0), r(2, 1), centre[2]);
    const cv::Matx33d ray_to_plane = plane_to_ray.inv();
    const double half_width = (picture.cols - 1) / 2.0, half_height = (picture.rows - 1) / 2.0;
    const auto sample = [&](const cv::Point2f& ray, bool& on_board) {
      const cv::Vec3d q = ray_to_plane * cv::Vec3d(ray.x, ray.y, 1.0);
      const double x = q[0] / q[2] / kPictureMetresPerPixel + half_width;
      const double y = q[1] / q[2] / kPictureMetresPerPixel + half_height;
      on_board = q[2] > 0 && x >= 0 && y >= 0 && x < picture.cols - 1 && y < picture.rows - 1;
      if (!on_board) return kBackground;
      const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
      const double fx = x - x0, fy = y - y0;
      const auto at = [&](int dy, int dx) {
        return static_cast<double>(picture.at<std::uint8_t>(y0 + dy, x0 + dx));
      };
      const double value = (at(0, 0) * (1 - fx) + at(0, 1) * fx) * (1 - fy) +
                           (at(1, 0) * (1 - fx) + at(1, 1) * fx) * fy;
      return 30.0 + value * (200.0 / 255.0);  // paper is not white, ink not black
    };
    cv::Mat image(camera_.size, CV_64FC1);
    const int width = camera_.size.width * kSamples;
    for (int v = 0; v < camera_.size.height; ++v) {
      for (int u = 0; u < camera_.size.width; ++u) {
        const auto index = [&](int su, int sv) {
          return static_cast<std::size_t>((v * kSamples + sv) * width + u * kSamples + su);
        };
        // Away from the board a pixel's four corner samples are all off it: no need for more.
        bool on_board = false, any_on_board = false;
        for (const auto& [su, sv] : {std::pair{0, 0},
                                     {kSamples - 1, 0},
                                     {0, kSamples - 1},
                                     {kSamples - 1, kSamples - 1}}) {
          sample(rays_[index(su, sv)], on_board);
          any_on_board = any_on_board || on_board;
        }
        double sum = 0;
        if (any_on_board) {
          for (int sv = 0; sv < kSamples; ++sv) {
            for (int su = 0; su < kSamples; ++su) sum += sample(rays_[index(su, sv)], on_board);
          }
        }
        image.at<double>(v, u) = any_on_board ? sum / (kSamples * kSamples) : kBackground;
      }
    }
    cv::Mat noise(camera_.size, CV_64FC1);
    cv::RNG(seed).fill(noise, cv::RNG::NORMAL, 0.0, 1.5);
    cv::Mat grey;
    cv::Mat(image + noise).convertTo(grey, CV_8UC1);
    return grey;
  }

 private:
  static constexpr double kBackground = 110.0;
  TrueCamera camera_;
  std::vector<cv::Point2f> rays_;  // per sample: the undistorted, normalised image point
};

const Renderer& renderer() {
  static const Renderer instance;
  return instance;
}

BoardSpec spec(const char* text) {
  std::string error;
  const std::optional<BoardSpec> parsed = parseBoardSpec(text, error);
  EXPECT_TRUE(parsed) << error;
  return parsed.value_or(BoardSpec{});
}

std::vector<cv::Mat> pictures(const char* board, const std::vector<Pose>& poses) {
  const BoardSpec board_spec = spec(board);
  const int margin = squarePixels(board_spec, 5000) / 2;
  const cv::Mat picture = boardPicture(board_spec, 5000, margin);
  std::vector<cv::Mat> images;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    images.push_back(renderer().render(picture, poses[i], static_cast<unsigned>(i + 1)));
  }
  return images;
}

// The ChArUco pictures of kPoses, rendered once for the tests that use them.
const std::vector<cv::Mat>& charucoPictures() {
  static const std::vector<cv::Mat> images = pictures(kCharuco, kPoses);
  return images;
}

std::vector<BoardCorners> cornersIn(const char* board, const std::vector<cv::Mat>& images) {
  std::vector<BoardCorners> views;
  for (const cv::Mat& image : images) views.push_back(findBoardCorners(spec(board), image));
  return views;
}

void expectTheTrueCamera(const char* board, const IntrinsicsResult& result) {
  ASSERT_TRUE(result.camera) << board << ": refused: " << result.report.refusal;
  const OpenCvParameters& found = *result.camera;
  const cv::Matx33d& truth = renderer().camera().matrix;
  const double fx_error = 100.0 * std::abs(found.fx / truth(0, 0) - 1.0);
  const double fy_error = 100.0 * std::abs(found.fy / truth(1, 1) - 1.0);
  const double principal_error = std::hypot(found.cx - truth(0, 2), found.cy - truth(1, 2));
  std::printf(
      "%s: fx %.3f (%.3f %%) fy %.3f (%.3f %%) principal point off by %.3f px, RMS %.3f px, "
      "%d views\n",
      board, found.fx, fx_error, found.fy, fy_error, principal_error, result.report.rms_px,
      result.report.usable_views);
  EXPECT_LT(fx_error, 0.5) << board << ": fx " << found.fx;
  EXPECT_LT(fy_error, 0.5) << board << ": fy " << found.fy;
  EXPECT_LT(principal_error, 2.0) << board << ": (" << found.cx << ", " << found.cy << ")";
  EXPECT_LT(result.report.rms_px, 0.3) << board;
  EXPECT_NEAR(found.distortion[0], -0.2, 0.02) << board << ": k1";
  EXPECT_EQ(found.width, 640);
  EXPECT_EQ(found.height, 480);
  EXPECT_EQ(found.rvec, Eigen::Vector3d::Zero());
  EXPECT_EQ(found.tvec, Eigen::Vector3d::Zero());
}

TEST(CalibrateIntrinsics, TheRendererIsExact) {
  EXPECT_LT(renderer().largestRayError(), 1e-3) << "the test's own undistortion is off";
}

// Where a corner is, in both boards: a board drawn square-on, 40 pixels a square, has its corners
// on pixel boundaries, which are at x.5 with pixel centres at whole numbers (OpenCV's convention
// and occmap's). OpenCV 4.6's interpolateCornersCharuco alone answers half a pixel further right
// and down; findBoardCorners must not.
TEST(CalibrateIntrinsics, CornersAreWhereTheSquaresMeet) {
  for (const char* text : {"charuco:7x5:0.04:0.03:DICT_4X4_50", "chessboard:6x4:0.04"}) {
    const BoardSpec board = spec(text);
    cv::Mat picture = boardPicture(board, 1000, 20);  // 40 pixels a square, 20 of margin
    ASSERT_EQ(squarePixels(board, 1000), 40);
    cv::GaussianBlur(picture, picture, cv::Size(5, 5), 1.0);  // a lens's softness
    const BoardCorners corners = findBoardCorners(board, picture);
    ASSERT_FALSE(corners.empty()) << text;
    double largest = 0;
    for (std::size_t i = 0; i < corners.size(); ++i) {
      // ChArUco's board points count from the board's outer corner, a chessboard's from its
      // first inner corner, one square in.
      const double squares_in = board.kind == BoardKind::kCharuco ? 0.0 : 1.0;
      const double x = 20 + 40 * (double{corners.board_points[i].x} / 0.04 + squares_in) - 0.5;
      const double y = 20 + 40 * (double{corners.board_points[i].y} / 0.04 + squares_in) - 0.5;
      largest = std::max(largest, std::hypot(double{corners.image_points[i].x} - x,
                                             double{corners.image_points[i].y} - y));
    }
    EXPECT_LT(largest, 0.05) << text;
  }
}

// A ChArUco board with an even number of rows as OpenCV 4.6 (Debian's) and later draw it, and as
// it was printed before (and still is by calib.io, and by later OpenCV with setLegacyPattern):
// its markers on the other squares, the top-left square white with marker 0 on it. Both are found,
// every corner where its squares meet.
TEST(CalibrateIntrinsics, BoardsOfEitherChArUcoLayoutAreFound) {
  const BoardSpec board = spec("charuco:7x6:0.04:0.03:DICT_4X4_50");
  const cv::Mat today = boardPicture(board, 1000, 20);  // 40 pixels a square, 20 of margin
  cv::Mat legacy(today.size(), CV_8UC1, cv::Scalar(255));
  const cv::Ptr<cv::aruco::Dictionary> dictionary =
      cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_50);
  int id = 0;
  for (int y = 0; y < 6; ++y) {
    for (int x = 0; x < 7; ++x) {
      const cv::Rect square(20 + 40 * x, 20 + 40 * y, 40, 40);
      if ((x + y) % 2 != 0) {
        legacy(square).setTo(0);
        continue;
      }
      cv::Mat marker;
      cv::aruco::drawMarker(dictionary, id++, 30, marker, 1);
      marker.copyTo(legacy(cv::Rect(square.x + 5, square.y + 5, 30, 30)));
    }
  }
  ASSERT_EQ(today.at<std::uint8_t>(25, 25), 0) << "OpenCV 4.6's layout: the top-left square black";
  for (const auto& [name, picture] : {std::pair{"4.6", today}, std::pair{"legacy", legacy}}) {
    cv::Mat soft;
    cv::GaussianBlur(picture, soft, cv::Size(5, 5), 1.0);
    const BoardCorners corners = findBoardCorners(board, soft);
    EXPECT_EQ(corners.size(), 30u) << name;
    double largest = 0;
    for (std::size_t i = 0; i < corners.size(); ++i) {
      const double x = 20 + 40 * (double{corners.board_points[i].x} / 0.04) - 0.5;
      const double y = 20 + 40 * (double{corners.board_points[i].y} / 0.04) - 0.5;
      largest = std::max(largest, std::hypot(double{corners.image_points[i].x} - x,
                                             double{corners.image_points[i].y} - y));
    }
    EXPECT_LT(largest, 0.05) << name;
  }
}

TEST(CalibrateIntrinsics, CharucoPicturesGiveBackTheCamera) {
  const std::vector<BoardCorners> views = cornersIn(kCharuco, charucoPictures());
  expectTheTrueCamera(kCharuco, calibrateIntrinsics(spec(kCharuco), views, cv::Size(640, 480)));
}

// A lens model that folds back inside its picture is refused: a barrel (k1 = -0.3) whose radial
// term turns at 1.054 normalised radius, inside a 640x480 picture's corners at focal 350 px and
// outside them at 600 px; and a rational model whose denominator reaches zero (a pole) at radius
// 0.466, inside the picture at 600 px, as cv::calibrateCamera fitted it to the pictures of
// CharucoPicturesGiveBackTheCamera with CALIB_RATIONAL_MODEL.
TEST(CalibrateIntrinsics, AModelThatFoldsInsideThePictureIsRefused) {
  OpenCvParameters barrel;
  barrel.width = 640;
  barrel.height = 480;
  barrel.cx = 319.5;
  barrel.cy = 239.5;
  barrel.distortion = {-0.3, 0.0, 0.0, 0.0, 0.0};
  barrel.fx = barrel.fy = 350.0;
  const std::string refusal = foldInsidePicture(barrel);
  // The first border pixel looked at: the top-left corner, 399 px from the principal point, where
  // the image of the turning radius is 1.054 (1 - 0.3 * 1.054^2) * 350 = 246 px from it.
  EXPECT_NE(refusal.find("folds back inside the picture: pixel (0, 0), 399 px from the principal "
                         "point, has no ray"),
            std::string::npos)
      << refusal;
  EXPECT_NE(refusal.find("take more pictures with the board right out in the picture's corners"),
            std::string::npos)
      << refusal;
  barrel.fx = barrel.fy = 600.0;
  EXPECT_EQ(foldInsidePicture(barrel), "");

  OpenCvParameters rational = barrel;
  rational.distortion = {0.3246, -21.441, 8.03e-4, -5.63e-4, -5.6268, 0.5184, -21.2926, -10.4126};
  EXPECT_NE(foldInsidePicture(rational), "");
  rational.distortion = {-0.2, 0.05, 0.001, -0.0005, 0.0, 0.01, 0.0, 0.0};
  EXPECT_EQ(foldInsidePicture(rational), "");
}

TEST(CalibrateIntrinsics, ChessboardPicturesGiveBackTheCamera) {
  const std::vector<BoardCorners> views = cornersIn(kChessboard, pictures(kChessboard, kPoses));
  int whole = 0;
  for (const BoardCorners& view : views) whole += view.size() == 54 ? 1 : 0;
  EXPECT_GE(whole, 11) << "the chessboard was not found in most pictures";
  expectTheTrueCamera(kChessboard,
                      calibrateIntrinsics(spec(kChessboard), views, cv::Size(640, 480)));
}

TEST(CalibrateIntrinsics, ThreePicturesAreTooFew) {
  std::vector<BoardCorners> views = cornersIn(kCharuco, charucoPictures());
  views.resize(3);
  const IntrinsicsResult result = calibrateIntrinsics(spec(kCharuco), views, cv::Size(640, 480));
  EXPECT_FALSE(result.camera);
  EXPECT_NE(result.report.refusal.find("3 usable pictures of the board, fewer than 6"),
            std::string::npos)
      << result.report.refusal;
}

TEST(CalibrateIntrinsics, PicturesOnlyInTheCentreCoverTooLittle) {
  std::vector<Pose> central;
  for (int i = 0; i < 7; ++i) {
    central.push_back({320.0 + 10 * (i % 3 - 1), 240.0 + 10 * (i % 2), 0.9, 25.0 * (i % 3 - 1),
                       20.0 * (i % 2 ? 1 : -1), 10.0 * i});
  }
  const std::vector<BoardCorners> views = cornersIn(kCharuco, pictures(kCharuco, central));
  const IntrinsicsResult result = calibrateIntrinsics(spec(kCharuco), views, cv::Size(640, 480));
  EXPECT_FALSE(result.camera);
  EXPECT_EQ(result.report.usable_views, 7);
  EXPECT_LT(result.report.covered_share, 0.5);
  const std::string& why = result.report.refusal;
  EXPECT_NE(why.find("the board covers too little of the image"), std::string::npos) << why;
  EXPECT_NE(why.find("top left"), std::string::npos) << why;
  EXPECT_NE(why.find("near the image's corners and edges"), std::string::npos) << why;
}

TEST(CalibrateIntrinsics, BadSpecsSayWhatIsWrong) {
  const auto error = [](const char* text) {
    std::string why;
    EXPECT_FALSE(parseBoardSpec(text, why)) << text;
    return why;
  };
  EXPECT_NE(error("charuco:7x5:0.04:0.04:DICT_4X4_50").find("must be smaller than its square"),
            std::string::npos);
  const std::string dictionary = error("charuco:7x5:0.04:0.03:DICT_4X4_51");
  EXPECT_NE(dictionary.find("unknown ArUco dictionary 'DICT_4X4_51'"), std::string::npos)
      << dictionary;
  EXPECT_NE(dictionary.find("DICT_4X4_50, DICT_4X4_100"), std::string::npos) << dictionary;
  EXPECT_NE(error("checkers:9x6:0.025").find("unknown board kind 'checkers'"), std::string::npos);
  EXPECT_NE(error("chessboard:9by6:0.025").find("COLUMNSxROWS"), std::string::npos);
  EXPECT_NE(error("chessboard:9x6:-1").find("length in metres"), std::string::npos);
  EXPECT_NE(error("charuco:20x20:0.04:0.03:DICT_4X4_50").find("has only 50"), std::string::npos);
  EXPECT_EQ(boardSpecText(spec(kCharuco)), kCharuco);
  EXPECT_EQ(boardSpecText(spec(kChessboard)), kChessboard);
}

TEST(CalibrateIntrinsicsCommand, WritesACalibrationOccmapReads) {
  TemporaryFolder folder;
  std::filesystem::create_directories(folder / "shots");
  const std::vector<cv::Mat>& images = charucoPictures();
  for (std::size_t i = 0; i < images.size(); ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "shots/%03zu.png", i);
    ASSERT_TRUE(cv::imwrite((folder / name).string(), images[i]));
  }
  const auto result = runCommand({kOccmap, "calibrate", "intrinsics", "--images",
                                  (folder / "shots" / "*.png").string(), "--board", kCharuco,
                                  "--out", (folder / "cam.yaml").string()});
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_NE(result.out.find("RMS reprojection error"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("012.png"), std::string::npos) << result.out;  // each picture's error
  EXPECT_NE(result.err.find("picture 13 of 13"), std::string::npos) << result.err;
  const OpenCvParameters camera = loadOpenCvYaml(folder / "cam.yaml");
  EXPECT_NEAR(camera.fx, 600.0, 3.0);
  EXPECT_EQ(camera.width, 640);
}

TEST(CalibrateIntrinsicsCommand, PicturesWithoutTheBoardSayWhatToDo) {
  TemporaryFolder folder;
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(cv::imwrite((folder / ("blank" + std::to_string(i) + ".png")).string(),
                            cv::Mat(480, 640, CV_8UC1, cv::Scalar(90 + 40 * i))));
  }
  const auto result =
      runCommand({kOccmap, "calibrate", "intrinsics", "--images", (folder / "*.png").string(),
                  "--board", kChessboard, "--out", (folder / "cam.yaml").string()});
  EXPECT_EQ(result.exit_code, 2) << result.err;
  EXPECT_NE(
      result.err.find("is in none of the 3 pictures (" + (folder / "blank0.png").string() + ", "),
      std::string::npos)
      << result.err;
  EXPECT_NE(result.err.find("blank2.png): check that --board"), std::string::npos) << result.err;
  EXPECT_FALSE(std::filesystem::exists(folder / "cam.yaml"));
}

TEST(CalibrateBoardCommand, WritesThePrintableBoardAndItsSize) {
  TemporaryFolder folder;
  const auto result = runCommand({kOccmap, "calibrate", "board", "--board", kChessboard, "--out",
                                  (folder / "board.png").string()});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  // 10 x 7 squares of 295 px (25 mm at 300 dpi) with a square's margin all round.
  const cv::Mat board = cv::imread((folder / "board.png").string(), cv::IMREAD_GRAYSCALE);
  EXPECT_EQ(board.cols, 12 * 295);
  EXPECT_EQ(board.rows, 9 * 295);
  EXPECT_NE(result.out.find("squares of 24.98 mm"), std::string::npos) << result.out;
  // Detected, at a quarter of the printed resolution (the detectors are slow on 3540 x 2655).
  cv::Mat smaller;
  cv::resize(board, smaller, cv::Size(), 0.25, 0.25, cv::INTER_AREA);
  EXPECT_EQ(findBoardCorners(spec(kChessboard), smaller).size(), 54u);
}

}  // namespace
}  // namespace occmap
