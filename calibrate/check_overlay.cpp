#include "calibrate/check_overlay.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>

#include <opencv2/imgproc.hpp>

namespace occmap {
namespace {

const cv::Scalar kOutline(0, 230, 255);  // BGR: yellow
const cv::Scalar kGrid(255, 220, 0);     // cyan
const cv::Scalar kMarker(255, 0, 255);   // magenta
const cv::Scalar kMaskEdge(0, 220, 0);   // green

// The world segment from a to b on the floor, drawn through the camera: sampled finely enough that
// the lens's curvature shows (every 2 cm, at most 2000 pieces), each piece drawn where both of its
// ends have an image. Whether any piece lies in the picture.
bool drawFloorSegment(cv::Mat& picture, const Camera& camera, const Eigen::Vector2d& a,
                      const Eigen::Vector2d& b, const cv::Scalar& colour, int thickness) {
  const double length = (b - a).norm();
  const int pieces = std::clamp(static_cast<int>(std::ceil(length / 0.02)), 1, 2000);
  std::optional<cv::Point2d> previous;
  bool inside = false;
  const cv::Rect frame(0, 0, picture.cols, picture.rows);
  for (int i = 0; i <= pieces; ++i) {
    const Eigen::Vector2d p = a + (b - a) * (static_cast<double>(i) / pieces);
    const std::optional<Eigen::Vector2d> pixel = camera.worldToStream({p.x(), p.y(), 0.0});
    std::optional<cv::Point2d> here;
    if (pixel) here = cv::Point2d(pixel->x(), pixel->y());
    if (previous && here) {
      // Pixel centres at integers; cv::line takes fixed-point coordinates for sub-pixel drawing.
      constexpr int kShift = 4;
      const auto fixed = [](const cv::Point2d& q) {
        return cv::Point(static_cast<int>(std::lround(q.x * (1 << kShift))),
                         static_cast<int>(std::lround(q.y * (1 << kShift))));
      };
      cv::line(picture, fixed(*previous), fixed(*here), colour, thickness, cv::LINE_AA, kShift);
      inside =
          inside || frame.contains(cv::Point(static_cast<int>(here->x), static_cast<int>(here->y)));
    }
    previous = here;
  }
  return inside;
}

void label(cv::Mat& picture, const std::string& text, cv::Point at, const cv::Scalar& colour) {
  cv::putText(picture, text, at, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 3,
              cv::LINE_AA);
  cv::putText(picture, text, at, cv::FONT_HERSHEY_SIMPLEX, 0.45, colour, 1, cv::LINE_AA);
}

}  // namespace

CheckOverlay drawCheckOverlay(const cv::Mat& grey, const Camera& camera, const MapGeometry& map,
                              const std::vector<FloorMarker>& markers, const Image* floor_mask) {
  CheckOverlay overlay;
  cv::cvtColor(grey, overlay.picture, cv::COLOR_GRAY2BGR);
  cv::Mat& picture = overlay.picture;

  if (floor_mask != nullptr && !floor_mask->empty()) {
    const cv::Mat mask(floor_mask->height(), floor_mask->width(), CV_8UC1,
                       const_cast<std::uint8_t*>(floor_mask->data()));
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(mask > 127, contours, cv::RETR_LIST, cv::CHAIN_APPROX_SIMPLE);
    cv::drawContours(picture, contours, -1, kMaskEdge, 1, cv::LINE_AA);
  }

  // The grid: every whole metre across the map.
  const double x0 = map.origin_x_m;
  const double y0 = map.origin_y_m;
  const double x1 = x0 + map.width * map.cell_size_m;
  const double y1 = y0 + map.height * map.cell_size_m;
  for (double x = std::ceil(x0); x <= x1; x += 1.0) {
    const bool in = drawFloorSegment(picture, camera, {x, y0}, {x, y1}, kGrid, x == 0.0 ? 2 : 1);
    overlay.grid_lines += in ? 1 : 0;
  }
  for (double y = std::ceil(y0); y <= y1; y += 1.0) {
    const bool in = drawFloorSegment(picture, camera, {x0, y}, {x1, y}, kGrid, y == 0.0 ? 2 : 1);
    overlay.grid_lines += in ? 1 : 0;
  }
  const Eigen::Vector2d corners[] = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
  for (int i = 0; i < 4; ++i) {
    drawFloorSegment(picture, camera, corners[i], corners[(i + 1) % 4], kOutline, 2);
  }

  for (const FloorMarker& marker : markers) {
    const auto c = markerCorners(marker);
    bool in = false;
    for (std::size_t i = 0; i < 4; ++i) {
      in =
          drawFloorSegment(picture, camera, c[i].head<2>(), c[(i + 1) % 4].head<2>(), kMarker, 1) ||
          in;
    }
    const std::optional<Eigen::Vector2d> top_left = camera.worldToStream(c[0]);
    if (in && top_left) {
      // A dot on corner 0 (OpenCV's top-left as printed) shows the marker's yaw is right.
      cv::circle(picture,
                 cv::Point(static_cast<int>(top_left->x()), static_cast<int>(top_left->y())), 3,
                 kMarker, cv::FILLED, cv::LINE_AA);
      label(picture, std::to_string(marker.id),
            cv::Point(static_cast<int>(top_left->x()) + 4, static_cast<int>(top_left->y()) - 4),
            kMarker);
    }
    overlay.markers_drawn += in ? 1 : 0;
  }
  label(picture, "map outline", {8, 18}, kOutline);
  label(picture, "1 m grid", {8, 36}, kGrid);
  if (!markers.empty()) label(picture, "markers (dot: top-left)", {8, 54}, kMarker);
  if (floor_mask != nullptr)
    label(picture, "floor mask edge", {8, markers.empty() ? 54 : 72}, kMaskEdge);
  return overlay;
}

}  // namespace occmap
