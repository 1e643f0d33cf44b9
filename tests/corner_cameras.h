#pragma once
// Cameras 3 m up at the corners of a 6 x 6 m floor, looking at its middle: ideal pinhole Tsai
// cameras of about 71 degrees across (footprints_test, zones_test).
#include <memory>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/camera.h"
#include "core/map_geometry.h"
#include "core/tsai_camera.h"

namespace occmap::testing {

inline Camera cornerCamera(const Eigen::Vector3d& position_m, int width = 320, int height = 240) {
  TsaiParameters p;
  p.width = width;
  p.height = height;
  p.ncx = p.nfx = p.width;
  p.dx = p.dy = p.dpx = p.dpy = 0.01;
  p.sx = 1.0;
  p.focal = 0.7 * p.dpx * p.width;  // a horizontal field of view of about 71 degrees
  p.kappa1 = 0.0;
  p.cx = p.width / 2.0;
  p.cy = p.height / 2.0;
  p.setPose(poseLookingAt(position_m * 1000.0, Eigen::Vector3d(3000, 3000, 0)));
  return Camera(std::make_shared<TsaiCamera>(p), LengthUnit::kMillimetre, width, height);
}

// The 6 x 6 m floor in 5 cm cells, and its four corner cameras 3 m up, half a metre outside it.
inline MapGeometry cornerRoomMap() {
  MapGeometry map;
  map.origin_x_m = 0.0;
  map.origin_y_m = 0.0;
  map.cell_size_m = 0.05;
  map.width = 120;
  map.height = 120;
  return map;
}

inline std::vector<Camera> cornerRoomCameras(int width = 320, int height = 240) {
  std::vector<Camera> cameras;
  for (const auto& [x, y] : {std::pair{-0.5, -0.5}, {6.5, -0.5}, {6.5, 6.5}, {-0.5, 6.5}}) {
    cameras.push_back(cornerCamera({x, y, 3.0}, width, height));
  }
  return cameras;
}

}  // namespace occmap::testing
