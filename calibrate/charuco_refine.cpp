#include "calibrate/charuco_refine.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace occmap {
namespace {

// A marker's square on the board (metres), grown by `margin` all round.
struct BoardRect {
  double x0, y0, x1, y1;
  bool holds(double x, double y, double margin) const {
    return x > x0 - margin && x < x1 + margin && y > y0 - margin && y < y1 + margin;
  }
};

cv::Point2d apply(const cv::Matx33d& h, double x, double y) {
  const cv::Vec3d p = h * cv::Vec3d(x, y, 1.0);
  return {p[0] / p[2], p[1] / p[2]};
}

}  // namespace

void refineCharucoCorners(const cv::Mat& grey, const cv::aruco::CharucoBoard& board,
                          BoardCorners& found) {
  const auto square = static_cast<double>(board.getSquareLength());
  std::vector<BoardRect> markers;
  for (const std::vector<cv::Point3f>& corners : board.objPoints) {
    BoardRect rect{1e9, 1e9, -1e9, -1e9};
    for (const cv::Point3f& p : corners) {
      rect.x0 = std::min(rect.x0, static_cast<double>(p.x));
      rect.y0 = std::min(rect.y0, static_cast<double>(p.y));
      rect.x1 = std::max(rect.x1, static_cast<double>(p.x));
      rect.y1 = std::max(rect.y1, static_cast<double>(p.y));
    }
    markers.push_back(rect);
  }
  cv::Mat image;
  grey.convertTo(image, CV_32F);
  const std::vector<cv::Point2f> given = found.image_points;  // the neighbours as OpenCV found them
  std::vector<cv::Point2f> board_near, image_near;
  std::vector<const BoardRect*> markers_near;
  for (std::size_t i = 0; i < found.size(); ++i) {
    const auto bx = static_cast<double>(found.board_points[i].x);
    const auto by = static_cast<double>(found.board_points[i].y);
    // The board around the corner, mapped into the picture by the corners found within one and a
    // half squares of it: near enough that the lens's distortion bends it little.
    board_near.clear();
    image_near.clear();
    for (std::size_t j = 0; j < found.size(); ++j) {
      if (std::hypot(static_cast<double>(found.board_points[j].x) - bx,
                     static_cast<double>(found.board_points[j].y) - by) <= 1.5 * square) {
        board_near.emplace_back(found.board_points[j].x, found.board_points[j].y);
        image_near.push_back(given[j]);
      }
    }
    if (board_near.size() < 4) continue;
    const cv::Mat fitted = cv::findHomography(board_near, image_near, 0);
    if (fitted.empty()) continue;
    const cv::Matx33d to_image(fitted);
    const cv::Matx33d to_board = to_image.inv();
    const cv::Point2d at = apply(to_image, bx, by);
    const double half = square / 2;
    const double pixels_per_metre = std::min(cv::norm(apply(to_image, bx + half, by) - at),
                                             cv::norm(apply(to_image, bx, by + half) - at)) /
                                    half;
    if (!(pixels_per_metre > 0)) continue;
    // Out to 0.3 of a square, at most 15 px: cornerSubPix takes the edges through the corner as
    // straight, and a wide lens bends them (the 3.5 mm cameras' calibration RMS 0.13 px with 0.45
    // of a square, 0.08 with 0.3).
    const int window = std::clamp(static_cast<int>(0.3 * square * pixels_per_metre), 2, 15);
    // A pixel and a half off the markers' edges: their blur, and a gradient's reach.
    const double margin = 1.5 / pixels_per_metre;
    markers_near.clear();
    for (const BoardRect& rect : markers) {
      if (rect.holds(bx, by, 1.5 * square)) markers_near.push_back(&rect);
    }

    const cv::Point2d start(static_cast<double>(given[i].x), static_cast<double>(given[i].y));
    cv::Point2d corner = start;
    const int side = 2 * window + 3;
    cv::Mat patch;
    bool settled = false;
    for (int iteration = 0; iteration < 30; ++iteration) {
      cv::getRectSubPix(image, cv::Size(side, side),
                        cv::Point2f(static_cast<float>(corner.x), static_cast<float>(corner.y)),
                        patch, CV_32F);
      double a = 0, b = 0, c = 0, bb1 = 0, bb2 = 0;
      for (int dy = -window; dy <= window; ++dy) {
        const float* above = patch.ptr<float>(window + dy);
        const float* row = patch.ptr<float>(window + 1 + dy);
        const float* below = patch.ptr<float>(window + 2 + dy);
        for (int dx = -window; dx <= window; ++dx) {
          const cv::Point2d on_board = apply(to_board, corner.x + dx, corner.y + dy);
          if (std::any_of(markers_near.begin(), markers_near.end(), [&](const BoardRect* m) {
                return m->holds(on_board.x, on_board.y, margin);
              })) {
            continue;
          }
          const int x = window + 1 + dx;
          const double gx =
              0.5 * (static_cast<double>(row[x + 1]) - static_cast<double>(row[x - 1]));
          const double gy = 0.5 * (static_cast<double>(below[x]) - static_cast<double>(above[x]));
          const double weight =
              std::exp(-(dx * dx + dy * dy) / static_cast<double>(window * window));
          a += weight * gx * gx;
          b += weight * gx * gy;
          c += weight * gy * gy;
          bb1 += weight * (gx * gx * dx + gx * gy * dy);
          bb2 += weight * (gx * gy * dx + gy * gy * dy);
        }
      }
      const double det = a * c - b * b;
      if (!(std::abs(det) > 1e-9 * (a * c + 1e-30))) break;
      const cv::Point2d step((c * bb1 - b * bb2) / det, (a * bb2 - b * bb1) / det);
      corner += step;
      if (cv::norm(corner - start) > 2.0) break;
      if (cv::norm(step) < 1e-3) {
        settled = true;
        break;
      }
    }
    if (settled)
      found.image_points[i] =
          cv::Point2f(static_cast<float>(corner.x), static_cast<float>(corner.y));
  }
}

}  // namespace occmap
