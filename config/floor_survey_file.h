#pragma once
// What a user measures on the floor to find a camera's pose (issue 15, docs/calibration.md):
// - markers.yaml: ArUco markers laid on the floor at measured places,
//     dictionary: DICT_4X4_50
//     markers:
//       - {id: 3, centre_m: [1.5, 2.0], side_m: 0.3, yaw_deg: 0}
//   (yaw_deg may be left out: 0). The dictionary is named as OpenCV names it; whether OpenCV knows
//   it is for the detector to say (calibrate/).
// - point pairs, CSV: a header `x_m,y_m,z_m,u,v`, then one world point (metres) and its pixel (u =
//   column, v = row, the top-left pixel's centre at (0, 0)) a line, measured by hand.
// Every problem is an InputError naming the file, the line and the field.

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "core/floor_marker.h"

namespace occmap {

struct FloorMarkers {
  std::string dictionary;
  std::vector<FloorMarker> markers;
  std::vector<int> lines;  // each marker's line in the file, for messages
};

FloorMarkers loadFloorMarkers(const std::filesystem::path& file);
FloorMarkers parseFloorMarkers(std::string_view text, const std::string& file_name);

struct PointPair {
  Eigen::Vector3d world_m = Eigen::Vector3d::Zero();
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  int line = 0;
};

std::vector<PointPair> loadPointPairs(const std::filesystem::path& file);

}  // namespace occmap
