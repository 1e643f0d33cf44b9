#pragma once
// Cameras 3 m up at the corners of a 6 x 6 m floor, looking at its middle: ideal pinhole Tsai
// cameras of about 71 degrees across (footprints_test, zones_test), and what they see of upright
// cylinders standing on it (people, and things wider and lower).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/camera.h"
#include "core/fusion_kernel.h"
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

// An upright cylinder on the floor.
struct Cylinder {
  double x_m = 0.0, y_m = 0.0;
  double radius_m = 0.2;
  double height_m = 1.75;
};

// The camera's changed pixels (core/fusion_kernel.h's tile layout): those whose ray passes
// through a cylinder.
inline std::vector<std::uint8_t> changedWhereCylinders(const Camera& camera,
                                                       const std::vector<Cylinder>& cylinders,
                                                       int width, int height) {
  std::vector<std::uint8_t> tiles(changedMaskBytes(width, height), 0);
  const std::size_t across = tilesAcross(width);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const std::optional<Ray> ray = camera.streamToRay({u, v});
      if (!ray) continue;
      const Eigen::Vector3d o = ray->origin, d = ray->direction;
      bool hit = false;
      for (const Cylinder& solid : cylinders) {
        // |o + t d - c| in the floor's plane = r: a quadratic in t.
        const double ox = o.x() - solid.x_m, oy = o.y() - solid.y_m;
        const double a = d.x() * d.x() + d.y() * d.y();
        const double b = 2 * (ox * d.x() + oy * d.y());
        const double c = ox * ox + oy * oy - solid.radius_m * solid.radius_m;
        const double discriminant = b * b - 4 * a * c;
        if (a <= 0 || discriminant < 0) continue;
        const double t0 = (-b - std::sqrt(discriminant)) / (2 * a);
        const double t1 = (-b + std::sqrt(discriminant)) / (2 * a);
        // Inside the cylinder for t in [t0, t1]: hit if z there meets [0, height].
        const double z0 = o.z() + t0 * d.z(), z1 = o.z() + t1 * d.z();
        if (t1 > 0 && std::max(z0, z1) >= 0 && std::min(z0, z1) <= solid.height_m) hit = true;
      }
      if (!hit) continue;
      const std::size_t tile =
          static_cast<std::size_t>(v / 8) * across + static_cast<std::size_t>(u / 8);
      tiles[tile * 8 + static_cast<std::size_t>(v % 8)] |= static_cast<std::uint8_t>(1 << (u % 8));
    }
  }
  return tiles;
}

}  // namespace occmap::testing
