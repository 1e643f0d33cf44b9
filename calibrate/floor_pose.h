#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "calibrate/marker_corners.h"
#include "core/floor_marker.h"
#include "core/opencv_camera.h"

namespace occmap {

// A camera's pose on the floor from ArUco markers laid at measured places, or from world points
// and their pixels measured by hand (issue 15, docs/calibration.md). The intrinsics are known
// (`occmap calibrate intrinsics`); what is found is OpenCV's rvec and tvec, world to camera.

struct MarkerFit {
  int id = 0;
  double reprojection_px = 0;  // RMS over its four corners
  double floor_error_cm = 0;   // mean distance between its corners seen (on the floor) and measured
  bool used = true;            // false: left out as not where markers.yaml puts it
};

struct PoseFit {
  Eigen::Vector3d rvec = Eigen::Vector3d::Zero();
  Eigen::Vector3d tvec = Eigen::Vector3d::Zero();
  double rms_px = 0;                  // reprojection RMS over every point used
  int points = 0;                     // points used
  std::vector<MarkerFit> markers;     // markers only, in the order of the sightings used
  std::vector<std::string> warnings;  // what constrains the pose poorly, in words
};

// The pose from the markers seen: every corner of every marker both seen and listed, solved with
// cv::solvePnP (IPPE: the corners lie on one plane, the floor), then refined by Levenberg-Marquardt
// over them all. A marker whose corners land far from the rest's fit (moved since it was measured,
// or its line in markers.yaml wrong) is left out and the pose found again without it. Nothing when
// fewer than one marker listed is seen; `error` says why.
std::optional<PoseFit> poseFromMarkers(const OpenCvParameters& intrinsics,
                                       const std::vector<FloorMarker>& markers,
                                       const std::vector<MarkerSighting>& seen, cv::Size image,
                                       std::string& error);

// The pose from world points (metres) and their pixels: IPPE when they all lie on the floor, else
// SQPnP; then refined. At least 4 points (6 or more advised); nothing with `error` otherwise.
std::optional<PoseFit> poseFromPoints(const OpenCvParameters& intrinsics,
                                      const std::vector<cv::Point3d>& world,
                                      const std::vector<cv::Point2d>& pixels, cv::Size image,
                                      std::string& error);

}  // namespace occmap
