// A camera's pose from markers on the floor (calibrate/floor_pose.h) and the markers file
// (config/floor_survey_file.h): exact corners give the exact pose, a marker moved since it was
// measured is left out, poor layouts are warned of, and each slip in markers.yaml is named.
#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "calibrate/floor_pose.h"
#include "config/floor_survey_file.h"
#include "config/input_error.h"
#include "input_error_of.h"
#include "temporary_folder.h"

namespace occmap {
namespace {

using testing::errorOf;
using testing::says;

// A 640 x 480 camera 2.6 m up in a corner of the room, looking down across the floor.
OpenCvParameters camera() {
  OpenCvParameters p;
  p.width = 640;
  p.height = 480;
  p.fx = 520;
  p.fy = 518;
  p.cx = 322.5;
  p.cy = 237.25;
  p.distortion = {-0.21, 0.06, 4e-4, -3e-4, 0.0};
  // Looking along +x and +y from (0, 0, 2.6), tilted 35 degrees down.
  const Eigen::Vector3d centre(0.0, 0.0, 2.6);
  const Eigen::Vector3d forward = Eigen::Vector3d(1, 1, -0.95).normalized();
  const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d r;
  r.row(0) = right;
  r.row(1) = down;
  r.row(2) = forward;
  p.rvec = rodriguesFromRotation(r);
  p.tvec = -r * centre;
  return p;
}

std::vector<FloorMarker> layout() {
  return {{0, {2.0, 1.5}, 0.3, 0},   {1, {3.5, 2.0}, 0.3, 30},  {2, {1.5, 3.5}, 0.3, -45},
          {3, {4.0, 4.0}, 0.4, 90},  {4, {5.5, 2.5}, 0.3, 180}, {5, {2.5, 5.5}, 0.4, 10},
          {6, {6.0, 5.0}, 0.4, -120}};
}

// What a detector would report: each marker's corners projected, with noise of `noise_px`.
std::vector<MarkerSighting> sightings(const OpenCvParameters& p,
                                      const std::vector<FloorMarker>& markers, double noise_px,
                                      std::mt19937& random) {
  std::normal_distribution<double> noise(0.0, noise_px);
  const cv::Mat k = (cv::Mat_<double>(3, 3) << p.fx, 0, p.cx, 0, p.fy, p.cy, 0, 0, 1);
  const cv::Mat d(1, 5, CV_64F, const_cast<double*>(p.distortion.data()));
  std::vector<MarkerSighting> seen;
  for (const FloorMarker& m : markers) {
    std::vector<cv::Point3d> corners;
    for (const Eigen::Vector3d& c : markerCorners(m)) corners.emplace_back(c.x(), c.y(), c.z());
    std::vector<cv::Point2d> pixels;
    cv::projectPoints(corners, cv::Vec3d(p.rvec.x(), p.rvec.y(), p.rvec.z()),
                      cv::Vec3d(p.tvec.x(), p.tvec.y(), p.tvec.z()), k, d, pixels);
    MarkerSighting s;
    s.id = m.id;
    for (std::size_t i = 0; i < 4; ++i) {
      s.corners[i] = cv::Point2f(static_cast<float>(pixels[i].x + noise(random)),
                                 static_cast<float>(pixels[i].y + noise(random)));
    }
    seen.push_back(s);
  }
  return seen;
}

Eigen::Vector3d centreOf(const Eigen::Vector3d& rvec, const Eigen::Vector3d& tvec) {
  return -rotationFromRodrigues(rvec).transpose() * tvec;
}

double degreesBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Matrix3d d = rotationFromRodrigues(a) * rotationFromRodrigues(b).transpose();
  return Eigen::AngleAxisd(d).angle() * 180 / std::numbers::pi;
}

TEST(PoseFromMarkers, CornersWithDetectorNoiseGiveThePose) {
  const OpenCvParameters truth = camera();
  OpenCvParameters intrinsics = truth;
  intrinsics.rvec.setZero();
  intrinsics.tvec.setZero();
  std::mt19937 random(5);
  const auto seen = sightings(truth, layout(), 0.1, random);
  std::string error;
  const auto fit = poseFromMarkers(intrinsics, layout(), seen, {640, 480}, error);
  ASSERT_TRUE(fit) << error;
  const double position_cm =
      100 * (centreOf(fit->rvec, fit->tvec) - centreOf(truth.rvec, truth.tvec)).norm();
  const double turn_deg = degreesBetween(fit->rvec, truth.rvec);
  std::printf("7 markers, 0.1 px noise: position %.3f cm, rotation %.4f deg, RMS %.3f px\n",
              position_cm, turn_deg, fit->rms_px);
  EXPECT_LT(position_cm, 1.0);
  EXPECT_LT(turn_deg, 0.1);
  EXPECT_LT(fit->rms_px, 0.3);
  EXPECT_EQ(fit->points, 28);
  ASSERT_EQ(fit->markers.size(), 7u);
  for (const MarkerFit& m : fit->markers) EXPECT_LT(m.floor_error_cm, 1.0) << m.id;
  EXPECT_TRUE(fit->warnings.empty()) << fit->warnings.front();
}

TEST(PoseFromMarkers, AMarkerMovedSinceItWasMeasuredIsLeftOut) {
  const OpenCvParameters truth = camera();
  std::mt19937 random(6);
  std::vector<FloorMarker> where_they_lie = layout();
  where_they_lie[3].centre_m += Eigen::Vector2d(0.25, -0.1);  // kicked aside
  const auto seen = sightings(truth, where_they_lie, 0.1, random);
  std::string error;
  const auto fit = poseFromMarkers(truth, layout(), seen, {640, 480}, error);
  ASSERT_TRUE(fit) << error;
  EXPECT_FALSE(fit->markers[3].used);
  EXPECT_LT(100 * (centreOf(fit->rvec, fit->tvec) - centreOf(truth.rvec, truth.tvec)).norm(), 1.0);
  bool said = false;
  for (const std::string& w : fit->warnings) said = said || w.find("marker 3 was left out") == 0;
  EXPECT_TRUE(said);
}

TEST(PoseFromMarkers, PoorLayoutsAreWarnedOf) {
  const OpenCvParameters truth = camera();
  std::mt19937 random(7);
  // Two markers: few. Four in a line: the turn about the line is weakly fixed.
  const std::vector<FloorMarker> two = {layout()[0], layout()[1]};
  const std::vector<FloorMarker> line = {
      {0, {2, 2}, 0.3, 0}, {1, {3, 3}, 0.3, 0}, {2, {4, 4}, 0.3, 0}, {3, {5, 5}, 0.3, 0}};
  std::string error;
  for (const auto& [markers, words] :
       {std::pair{two, std::string("only 2 marker")}, std::pair{line, std::string("line")}}) {
    const auto fit =
        poseFromMarkers(truth, markers, sightings(truth, markers, 0.1, random), {640, 480}, error);
    ASSERT_TRUE(fit) << error;
    bool said = false;
    for (const std::string& w : fit->warnings) said = said || w.find(words) != std::string::npos;
    EXPECT_TRUE(said) << words;
  }
  // None of the markers seen is listed: no pose.
  const std::vector<FloorMarker> others = {{40, {1, 1}, 0.3, 0}};
  EXPECT_FALSE(
      poseFromMarkers(truth, others, sightings(truth, layout(), 0.1, random), {640, 480}, error));
  EXPECT_NE(error.find("none of the markers seen"), std::string::npos);
}

TEST(PoseFromPoints, HandMeasuredPointsOnAndOffTheFloor) {
  const OpenCvParameters truth = camera();
  std::vector<cv::Point3d> world = {{2, 1, 0},   {4, 1.5, 0}, {1.5, 4, 0},    {5, 5, 0},
                                    {3, 3, 1.2}, {6, 2, 0.8}, {2.5, 5.5, 2.0}};
  const cv::Mat k =
      (cv::Mat_<double>(3, 3) << truth.fx, 0, truth.cx, 0, truth.fy, truth.cy, 0, 0, 1);
  const cv::Mat d(1, 5, CV_64F, const_cast<double*>(truth.distortion.data()));
  std::vector<cv::Point2d> pixels;
  cv::projectPoints(world, cv::Vec3d(truth.rvec.x(), truth.rvec.y(), truth.rvec.z()),
                    cv::Vec3d(truth.tvec.x(), truth.tvec.y(), truth.tvec.z()), k, d, pixels);
  std::string error;
  const auto fit = poseFromPoints(truth, world, pixels, {640, 480}, error);
  ASSERT_TRUE(fit) << error;
  EXPECT_LT((centreOf(fit->rvec, fit->tvec) - centreOf(truth.rvec, truth.tvec)).norm(), 1e-6);
  EXPECT_LT(fit->rms_px, 1e-6);
  world.resize(3);
  pixels.resize(3);
  EXPECT_FALSE(poseFromPoints(truth, world, pixels, {640, 480}, error));
  EXPECT_NE(error.find("at least 4 points"), std::string::npos);
}

TEST(MarkersFile, ReadsTheIssuesLayoutAndNamesEachSlip) {
  const FloorMarkers read = parseFloorMarkers(
      "dictionary: DICT_4X4_50\nmarkers:\n  - {id: 3, centre_m: [1.5, 2], side_m: 0.3, yaw_deg: "
      "90}\n  - {id: 4, centre_m: [-1, 0.25], side_m: 0.4}\n",
      "markers.yaml");
  EXPECT_EQ(read.dictionary, "DICT_4X4_50");
  ASSERT_EQ(read.markers.size(), 2u);
  EXPECT_EQ(read.markers[0].id, 3);
  EXPECT_EQ(read.markers[0].yaw_deg, 90);
  EXPECT_EQ(read.markers[1].yaw_deg, 0);  // left out: 0
  EXPECT_EQ(read.lines[1], 4);
  // Corner 0, top-left as printed, of a marker of yaw 90: right is +y, up is -x, so corner 0 at
  // centre + side/2 (up - right) = centre + 0.15 (-1, -1); corner 1 (top-right) at centre + 0.15
  // (-1, +1).
  const auto corners = markerCorners(read.markers[0]);
  EXPECT_NEAR(corners[0].x(), 1.35, 1e-12);
  EXPECT_NEAR(corners[0].y(), 1.85, 1e-12);
  EXPECT_NEAR(corners[1].x(), 1.35, 1e-12);
  EXPECT_NEAR(corners[1].y(), 2.15, 1e-12);

  const InputError twice = errorOf([] {
    parseFloorMarkers(
        "dictionary: DICT_4X4_50\nmarkers:\n  - {id: 3, centre_m: [0, 0], side_m: "
        "0.3}\n  - {id: 3, centre_m: [1, 0], side_m: 0.3}\n",
        "m.yaml");
  });
  EXPECT_EQ(twice.line(), 4);
  EXPECT_NE(std::string(twice.what()).find("lines 3 and 4"), std::string::npos) << twice.what();
  const InputError side = errorOf([] {
    parseFloorMarkers(
        "dictionary: DICT_4X4_50\nmarkers:\n  - {id: 1, centre_m: [0, 0], side_m: "
        "-0.3}\n",
        "m.yaml");
  });
  EXPECT_EQ(side.field(), "markers[0].side_m");
  const InputError key = errorOf([] {
    parseFloorMarkers("dictionary: DICT_4X4_50\nmarkers:\n  - {id: 1, centre: [0, 0]}\n", "m.yaml");
  });
  EXPECT_EQ(key.field(), "markers[0].centre");
  const InputError none = errorOf([] { parseFloorMarkers("dictionary: DICT_4X4_50\n", "m.yaml"); });
  EXPECT_EQ(none.field(), "markers");

  const testing::TemporaryFolder folder;
  const auto pairs = loadPointPairs(folder.write("p.csv", "x_m,y_m,z_m,u,v\n1,2,0,100.5,200\n"));
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0].pixel.x(), 100.5);
  const InputError header =
      errorOf([&] { loadPointPairs(folder.write("q.csv", "x,y,z,u,v\n1,2,0,3,4\n")); });
  EXPECT_EQ(header.line(), 1);
}

}  // namespace
}  // namespace occmap
