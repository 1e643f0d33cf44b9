#include "calibrate/floor_pose.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <Eigen/Eigenvalues>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

namespace occmap {
namespace {

// Markers agree on a pose when their corners land within this many pixels (RMS) of where it puts
// them: detections are good to a few tenths of a pixel, and a pose from three markers predicts the
// others to about a pixel; a marker 10 cm from its place, 5 m away, is off by tens of pixels.
constexpr double kAgreePixels = 3.0;

// A number for a message, with `decimals` decimals.
std::string fixed(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", decimals, value);
  return text;
}

cv::Mat cameraMatrix(const OpenCvParameters& p) {
  return (cv::Mat_<double>(3, 3) << p.fx, 0, p.cx, 0, p.fy, p.cy, 0, 0, 1);
}

// All 12 of OpenCV's coefficients: the usual 5, then the rational and thin prism terms (zero for a
// usual lens, which OpenCV then treats exactly as the 5-coefficient model).
cv::Mat distortionCoefficients(const OpenCvParameters& p) {
  return cv::Mat(p.distortion, true).reshape(1, 1);
}

struct Solution {
  cv::Vec3d rvec;
  cv::Vec3d tvec;
};

// IPPE for points on one plane (the floor: z = 0 for all), else SQPnP; then Levenberg-Marquardt
// over every point, as the issue asks.
Solution solve(const OpenCvParameters& p, const std::vector<cv::Point3d>& world,
               const std::vector<cv::Point2d>& pixels) {
  const bool planar =
      std::all_of(world.begin(), world.end(), [](const cv::Point3d& w) { return w.z == 0.0; });
  const cv::Mat k = cameraMatrix(p);
  const cv::Mat d = distortionCoefficients(p);
  Solution s;
  cv::solvePnP(world, pixels, k, d, s.rvec, s.tvec, false,
               planar ? cv::SOLVEPNP_IPPE : cv::SOLVEPNP_SQPNP);
  cv::solvePnPRefineLM(world, pixels, k, d, s.rvec, s.tvec);
  return s;
}

std::vector<double> reprojectionErrors(const OpenCvParameters& p, const Solution& s,
                                       const std::vector<cv::Point3d>& world,
                                       const std::vector<cv::Point2d>& pixels) {
  std::vector<cv::Point2d> projected;
  cv::projectPoints(world, s.rvec, s.tvec, cameraMatrix(p), distortionCoefficients(p), projected);
  std::vector<double> errors(world.size());
  for (std::size_t i = 0; i < world.size(); ++i) errors[i] = cv::norm(projected[i] - pixels[i]);
  return errors;
}

double rms(const std::vector<double>& errors, std::size_t first, std::size_t count) {
  double sum = 0;
  for (std::size_t i = first; i < first + count; ++i) sum += errors[i] * errors[i];
  return count == 0 ? 0.0 : std::sqrt(sum / static_cast<double>(count));
}

// Where each pixel's ray meets the floor (z = 0) under the pose; NaN where it does not.
std::vector<Eigen::Vector3d> onTheFloor(const OpenCvParameters& p, const Solution& s,
                                        const std::vector<cv::Point2d>& pixels) {
  std::vector<cv::Point2d> normalised;
  cv::undistortPoints(pixels, normalised, cameraMatrix(p), distortionCoefficients(p));
  cv::Matx33d r;
  cv::Rodrigues(s.rvec, r);
  Eigen::Matrix3d rotation;
  cv::cv2eigen(cv::Mat(r), rotation);
  const Eigen::Vector3d t(s.tvec[0], s.tvec[1], s.tvec[2]);
  const Eigen::Vector3d centre = -rotation.transpose() * t;
  std::vector<Eigen::Vector3d> points;
  for (const cv::Point2d& n : normalised) {
    const Eigen::Vector3d ray = rotation.transpose() * Eigen::Vector3d(n.x, n.y, 1.0);
    const double along = -centre.z() / ray.z();
    points.push_back(along > 0 ? Eigen::Vector3d(centre + along * ray)
                               : Eigen::Vector3d::Constant(std::nan("")));
  }
  return points;
}

// What constrains the pose poorly, in words a person laying markers can act on.
std::vector<std::string> poseWarnings(const std::vector<cv::Point3d>& world,
                                      const std::vector<cv::Point2d>& pixels, cv::Size image,
                                      const Solution& s, int markers) {
  std::vector<std::string> warnings;
  if (markers > 0 && markers < 3) {
    warnings.push_back("only " + std::to_string(markers) +
                       " marker(s) seen: the pose rests on few points; lay 4 or more spread "
                       "over the camera's view");
  }
  // Spread of the points on the floor: a line leaves the turn about it weakly fixed.
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const cv::Point3d& w : world) mean += Eigen::Vector2d(w.x, w.y);
  mean /= static_cast<double>(world.size());
  Eigen::Matrix2d spread = Eigen::Matrix2d::Zero();
  for (const cv::Point3d& w : world) {
    const Eigen::Vector2d d = Eigen::Vector2d(w.x, w.y) - mean;
    spread += d * d.transpose();
  }
  const Eigen::Vector2d axes = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(spread).eigenvalues();
  if (axes.y() > 0 && std::sqrt(std::max(0.0, axes.x()) / axes.y()) < 0.15) {
    warnings.push_back(
        "the points lie nearly in a line on the floor: the camera may turn about it unseen; add "
        "markers (or points) off that line");
  }
  // Coverage of the image: points bunched in a corner of the view, far away, fix it poorly.
  std::vector<cv::Point2f> image_points(pixels.begin(), pixels.end());
  std::vector<cv::Point2f> hull;
  cv::convexHull(image_points, hull);
  const double share = cv::contourArea(hull) / (static_cast<double>(image.area()));
  if (share < 0.05) {
    warnings.push_back("the points cover " + fixed(100 * share, 1) + " % of the image: " +
                       "spread markers over more of the view, nearer the camera, or use larger "
                       "ones");
  }
  cv::Matx33d r;
  cv::Rodrigues(s.rvec, r);
  const cv::Vec3d centre = -(r.t() * s.tvec);
  if (!(centre[2] > 0)) {
    warnings.push_back("the camera comes out " + fixed(-centre[2], 2) + " m below the floor: " +
                       "check the markers' places and ids in the markers file (a mirrored "
                       "x or y, swapped ids)");
  }
  return warnings;
}

PoseFit fitOf(const Solution& s, const std::vector<double>& errors) {
  PoseFit fit;
  fit.rvec = {s.rvec[0], s.rvec[1], s.rvec[2]};
  fit.tvec = {s.tvec[0], s.tvec[1], s.tvec[2]};
  fit.rms_px = rms(errors, 0, errors.size());
  fit.points = static_cast<int>(errors.size());
  return fit;
}

// Which markers agree on one pose (four points each, marker by marker in `world`, `pixels`): a
// least-squares fit spreads one misplaced marker's error over all and hides it, so every three
// markers give a pose, and the largest set of markers whose corners land within kAgreePixels
// (RMS) of it agree. With three markers or fewer all are kept.
std::vector<bool> agreeingMarkers(const OpenCvParameters& p, const std::vector<cv::Point3d>& world,
                                  const std::vector<cv::Point2d>& pixels) {
  const std::size_t n = world.size() / 4;
  std::vector<bool> best(n, true);
  if (n < 4) return best;
  std::size_t best_count = 0;
  double best_error = 0;
  const auto corners = [&](std::initializer_list<std::size_t> ms) {
    std::pair<std::vector<cv::Point3d>, std::vector<cv::Point2d>> points;
    for (const std::size_t m : ms) {
      for (std::size_t k = 4 * m; k < 4 * m + 4; ++k) {
        points.first.push_back(world[k]);
        points.second.push_back(pixels[k]);
      }
    }
    return points;
  };
  // Every three of up to 12 markers (220 poses); past that, the first 12 with every other.
  const std::size_t first = std::min<std::size_t>(n, 12);
  for (std::size_t a = 0; a < first; ++a) {
    for (std::size_t b = a + 1; b < first; ++b) {
      for (std::size_t c = b + 1; c < n; ++c) {
        const auto [w, px] = corners({a, b, c});
        const Solution s = solve(p, w, px);
        const std::vector<double> errors = reprojectionErrors(p, s, world, pixels);
        std::vector<bool> agree(n);
        std::size_t count = 0;
        double error = 0;
        for (std::size_t m = 0; m < n; ++m) {
          const double e = rms(errors, 4 * m, 4);
          agree[m] = e <= kAgreePixels;
          count += agree[m] ? 1 : 0;
          error += agree[m] ? e : 0.0;
        }
        if (count > best_count || (count == best_count && error < best_error)) {
          best = agree;
          best_count = count;
          best_error = error;
        }
      }
    }
  }
  return best;
}

}  // namespace

std::optional<PoseFit> poseFromMarkers(const OpenCvParameters& intrinsics,
                                       const std::vector<FloorMarker>& markers,
                                       const std::vector<MarkerSighting>& seen, cv::Size image,
                                       std::string& error) {
  // The markers both seen and listed; one seen twice is ambiguous and left out.
  std::vector<const FloorMarker*> listed;
  std::vector<const MarkerSighting*> sightings;
  for (const MarkerSighting& sighting : seen) {
    const auto twice = std::count_if(seen.begin(), seen.end(),
                                     [&](const MarkerSighting& s) { return s.id == sighting.id; });
    const auto found = std::find_if(markers.begin(), markers.end(),
                                    [&](const FloorMarker& m) { return m.id == sighting.id; });
    if (twice == 1 && found != markers.end()) {
      listed.push_back(&*found);
      sightings.push_back(&sighting);
    }
  }
  if (listed.empty()) {
    error = "none of the markers seen is in the markers file";
    return std::nullopt;
  }
  // Each marker's four corners on the floor and in the image, marker by marker.
  std::vector<cv::Point3d> world;
  std::vector<cv::Point2d> pixels;
  for (std::size_t m = 0; m < listed.size(); ++m) {
    const auto corners = markerCorners(*listed[m]);
    for (std::size_t c = 0; c < 4; ++c) {
      world.emplace_back(corners[c].x(), corners[c].y(), 0.0);
      pixels.emplace_back(sightings[m]->corners[c]);
    }
  }
  const std::vector<bool> used = agreeingMarkers(intrinsics, world, pixels);
  std::vector<cv::Point3d> used_world;
  std::vector<cv::Point2d> used_pixels;
  for (std::size_t k = 0; k < world.size(); ++k) {
    if (!used[k / 4]) continue;
    used_world.push_back(world[k]);
    used_pixels.push_back(pixels[k]);
  }
  const Solution s = solve(intrinsics, used_world, used_pixels);
  PoseFit fit = fitOf(s, reprojectionErrors(intrinsics, s, used_world, used_pixels));
  // Every marker's errors under the pose, those left out too (they show how far off they are).
  const std::vector<double> errors = reprojectionErrors(intrinsics, s, world, pixels);
  const std::vector<Eigen::Vector3d> floor = onTheFloor(intrinsics, s, pixels);
  int count = 0;
  for (std::size_t m = 0; m < listed.size(); ++m) {
    MarkerFit marker;
    marker.id = listed[m]->id;
    marker.used = used[m];
    marker.reprojection_px = rms(errors, 4 * m, 4);
    double distance = 0;
    for (std::size_t k = 4 * m; k < 4 * m + 4; ++k) {
      distance += (floor[k] - Eigen::Vector3d(world[k].x, world[k].y, 0.0)).norm();
    }
    marker.floor_error_cm = 100 * distance / 4;
    fit.markers.push_back(marker);
    count += used[m] ? 1 : 0;
  }
  fit.warnings = poseWarnings(used_world, used_pixels, image, s, count);
  for (const MarkerFit& mf : fit.markers) {
    if (!mf.used) {
      fit.warnings.push_back("marker " + std::to_string(mf.id) + " was left out: it lies " +
                             fixed(mf.floor_error_cm, 1) +
                             " cm from where the markers file puts it (moved since it was "
                             "measured, or its line is wrong)");
    }
  }
  return fit;
}

std::optional<PoseFit> poseFromPoints(const OpenCvParameters& intrinsics,
                                      const std::vector<cv::Point3d>& world,
                                      const std::vector<cv::Point2d>& pixels, cv::Size image,
                                      std::string& error) {
  if (world.size() < 4 || world.size() != pixels.size()) {
    error = "a pose needs at least 4 points (6 or more, spread over the view, are advised); " +
            std::to_string(world.size()) + " given";
    return std::nullopt;
  }
  const Solution s = solve(intrinsics, world, pixels);
  PoseFit fit = fitOf(s, reprojectionErrors(intrinsics, s, world, pixels));
  fit.warnings = poseWarnings(world, pixels, image, s, 0);
  if (world.size() < 6) {
    fit.warnings.push_back("only " + std::to_string(world.size()) +
                           " points: the pose has little to check it; measure 6 or more");
  }
  return fit;
}

}  // namespace occmap
