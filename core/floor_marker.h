#pragma once

#include <array>

#include <Eigen/Core>

namespace occmap {

// An ArUco marker printed on paper and laid flat on the floor at a measured place, by which a
// camera finds its pose (issue 15, docs/calibration.md). `side_m` is the side of the black square,
// its black border included (OpenCV's marker length). The marker's printed left-to-right direction
// lies along (cos yaw, sin yaw, 0) and its printed upward direction along (-sin yaw, cos yaw, 0).
struct FloorMarker {
  int id = 0;
  Eigen::Vector2d centre_m = Eigen::Vector2d::Zero();
  double side_m = 0.0;
  double yaw_deg = 0.0;
};

// The marker's corners on the floor (z = 0) in OpenCV's order: top-left, top-right, bottom-right,
// bottom-left as printed. The top-left is centre + side/2 (up - right). Seen from above the paper
// is not mirrored (from "right" to "up" turns counter-clockwise, as from x to y), so the order is
// clockwise on the paper as on the floor seen from above.
std::array<Eigen::Vector3d, 4> markerCorners(const FloorMarker& marker);

}  // namespace occmap
