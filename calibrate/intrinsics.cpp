#include "calibrate/intrinsics.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <set>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace occmap {
namespace {

// Why a view cannot be used, or nothing when it can.
std::optional<std::string> unusable(const BoardSpec& spec, const BoardCorners& view) {
  if (view.empty()) return "no board found";
  const int least = std::max(kMinCornersPerView, (spec.cornerCount() + 3) / 4);
  if (static_cast<int>(view.size()) < least) {
    return std::to_string(view.size()) + " corners, fewer than " + std::to_string(least);
  }
  // Corners on one line of the board say nothing about the plane's tilt.
  std::set<float> xs, ys;
  for (const cv::Point3f& point : view.board_points) {
    xs.insert(point.x);
    ys.insert(point.y);
  }
  if (xs.size() < 2 || ys.size() < 2) return "its corners lie on one line of the board";
  return std::nullopt;
}

// The share of the image that the union of the views' convex hulls covers, measured on a mask of
// at most about 1000 pixels across (a share, so the resolution hardly matters).
double coveredShare(const std::vector<const BoardCorners*>& views, cv::Size image_size) {
  const double scale = std::min(1.0, 1000.0 / std::max(image_size.width, image_size.height));
  const cv::Size mask_size(std::max(1, static_cast<int>(image_size.width * scale)),
                           std::max(1, static_cast<int>(image_size.height * scale)));
  cv::Mat mask(mask_size, CV_8UC1, cv::Scalar(0));
  for (const BoardCorners* view : views) {
    std::vector<cv::Point2f> hull;
    cv::convexHull(view->image_points, hull);
    std::vector<cv::Point> scaled;
    for (const cv::Point2f& point : hull) {
      scaled.emplace_back(static_cast<int>(std::lround(static_cast<double>(point.x) * scale)),
                          static_cast<int>(std::lround(static_cast<double>(point.y) * scale)));
    }
    cv::fillConvexPoly(mask, scaled, cv::Scalar(255));
  }
  return static_cast<double>(cv::countNonZero(mask)) / static_cast<double>(mask.total());
}

std::string percentText(double share) {
  char text[16];
  std::snprintf(text, sizeof text, "%.0f %%", 100.0 * share);
  return text;
}

}  // namespace

const char* gridCellName(int cell) {
  static constexpr std::array<const char*, 9> kNames{"top left",    "top",    "top right",
                                                     "left",        "centre", "right",
                                                     "bottom left", "bottom", "bottom right"};
  return kNames.at(static_cast<std::size_t>(cell));
}

OpenCvParameters openCvIntrinsics(const cv::Mat& camera_matrix, const cv::Mat& distortion,
                                  cv::Size image_size) {
  OpenCvParameters camera;
  camera.width = image_size.width;
  camera.height = image_size.height;
  camera.fx = camera_matrix.at<double>(0, 0);
  camera.fy = camera_matrix.at<double>(1, 1);
  camera.cx = camera_matrix.at<double>(0, 2);
  camera.cy = camera_matrix.at<double>(1, 2);
  for (std::size_t i = 0; i < 5; ++i)
    camera.distortion[i] = distortion.at<double>(static_cast<int>(i));
  return camera;
}

IntrinsicsResult calibrateIntrinsics(const BoardSpec& spec, const std::vector<BoardCorners>& views,
                                     cv::Size image_size) {
  IntrinsicsResult result;
  IntrinsicsReport& report = result.report;
  std::vector<const BoardCorners*> used;
  for (const BoardCorners& view : views) {
    ViewReport& view_report = report.views.emplace_back();
    view_report.corners = static_cast<int>(view.size());
    if (const auto why = unusable(spec, view)) {
      view_report.why_not = *why;
      continue;
    }
    view_report.used = true;
    used.push_back(&view);
  }
  report.usable_views = static_cast<int>(used.size());
  for (const BoardCorners* view : used) {
    for (const cv::Point2f& point : view->image_points) {
      const int column =
          std::clamp(static_cast<int>(3.0 * static_cast<double>(point.x) / image_size.width), 0, 2);
      const int row = std::clamp(
          static_cast<int>(3.0 * static_cast<double>(point.y) / image_size.height), 0, 2);
      report.cell_reached[static_cast<std::size_t>(3 * row + column)] = true;
    }
  }
  report.covered_share = used.empty() ? 0.0 : coveredShare(used, image_size);

  if (report.usable_views < kMinViews) {
    report.refusal = std::to_string(report.usable_views) + " usable picture" +
                     (report.usable_views == 1 ? "" : "s") + " of the board, fewer than " +
                     std::to_string(kMinViews) + ": take at least " + std::to_string(kMinViews) +
                     " (better 15 to 25) with the whole board sharp and in view, tilted up to "
                     "about 40 degrees in different directions";
    return result;
  }
  std::string missing;
  for (int cell = 0; cell < 9; ++cell) {
    if (report.cell_reached[static_cast<std::size_t>(cell)]) continue;
    missing += std::string(missing.empty() ? "" : ", ") + gridCellName(cell);
  }
  if (report.covered_share < kMinCoveredShare || !missing.empty()) {
    report.refusal = "the board covers too little of the image: its pictures together cover " +
                     percentText(report.covered_share) + " (at least " +
                     percentText(kMinCoveredShare) + " needed)";
    if (!missing.empty()) report.refusal += " and never reach the image's " + missing;
    report.refusal +=
        ": take more pictures with the board near the image's corners and edges, where the lens "
        "distorts most";
    return result;
  }

  std::vector<std::vector<cv::Point3f>> board_points;
  std::vector<std::vector<cv::Point2f>> image_points;
  for (const BoardCorners* view : used) {
    board_points.push_back(view->board_points);
    image_points.push_back(view->image_points);
  }
  cv::Mat camera_matrix;
  cv::Mat distortion;
  std::vector<cv::Mat> rvecs, tvecs;
  cv::Mat intrinsic_sigmas, extrinsic_sigmas, view_errors;
  // flags 0: k1 k2 p1 p2 k3 and zero skew, the model occmap's OpenCV YAML holds.
  const cv::TermCriteria until(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, DBL_EPSILON);
  report.rms_px =
      cv::calibrateCamera(board_points, image_points, image_size, camera_matrix, distortion, rvecs,
                          tvecs, intrinsic_sigmas, extrinsic_sigmas, view_errors, 0, until);
  std::size_t next = 0;
  for (ViewReport& view_report : report.views) {
    if (view_report.used) view_report.rms_px = view_errors.at<double>(static_cast<int>(next++));
  }
  report.fx_sigma_px = intrinsic_sigmas.at<double>(0);
  report.fy_sigma_px = intrinsic_sigmas.at<double>(1);
  report.cx_sigma_px = intrinsic_sigmas.at<double>(2);
  report.cy_sigma_px = intrinsic_sigmas.at<double>(3);

  const OpenCvParameters camera = openCvIntrinsics(camera_matrix, distortion, image_size);
  report.refusal = foldInsidePicture(camera);
  if (report.refusal.empty()) result.camera = camera;
  return result;
}

double principalPointTurnDeg(const OpenCvParameters& camera, const IntrinsicsReport& report) {
  const double across = std::atan(report.cx_sigma_px / camera.fx);
  const double down = std::atan(report.cy_sigma_px / camera.fy);
  return std::max(across, down) * 180.0 / std::numbers::pi;
}

std::string foldInsidePicture(const OpenCvParameters& camera) {
  const OpenCvCamera model(camera);
  // Along the picture's border, where the model is furthest out: every 4 pixels and each corner,
  // pixel centres.
  const double right = camera.width - 1.0, bottom = camera.height - 1.0;
  std::vector<Eigen::Vector2d> border;
  for (double u = 0; u < right; u += 4) border.insert(border.end(), {{u, 0.0}, {u, bottom}});
  for (double v = 0; v < bottom; v += 4) border.insert(border.end(), {{0.0, v}, {right, v}});
  border.emplace_back(right, bottom);
  for (const Eigen::Vector2d& pixel : border) {
    if (model.imageToRay(pixel)) continue;
    char where[256];
    std::snprintf(where, sizeof where,
                  "the lens model found folds back inside the picture: pixel (%.0f, %.0f), %.0f px "
                  "from the principal point, has no ray (past it the model's radial term no "
                  "longer increases)",
                  pixel.x(), pixel.y(), std::hypot(pixel.x() - camera.cx, pixel.y() - camera.cy));
    return std::string(where) +
           ": it is wrong there; take more pictures with the board right out in the picture's "
           "corners, tilted, so that the distortion is measured where it is strongest";
  }
  return "";
}

}  // namespace occmap
