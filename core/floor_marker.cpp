#include "core/floor_marker.h"

#include <cmath>
#include <numbers>

namespace occmap {

std::array<Eigen::Vector3d, 4> markerCorners(const FloorMarker& marker) {
  const double yaw = marker.yaw_deg * std::numbers::pi / 180.0;
  const Eigen::Vector2d right(std::cos(yaw), std::sin(yaw));
  const Eigen::Vector2d up(-std::sin(yaw), std::cos(yaw));
  const double half = marker.side_m / 2;
  const auto at = [&](double along_right, double along_up) {
    const Eigen::Vector2d p = marker.centre_m + half * (along_right * right + along_up * up);
    return Eigen::Vector3d(p.x(), p.y(), 0.0);
  };
  return {at(-1, 1), at(1, 1), at(1, -1), at(-1, -1)};
}

}  // namespace occmap
