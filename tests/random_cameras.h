#pragma once
// Random but plausible cameras and maps for property tests: a fixed seed keeps failures repeatable.

#include <memory>
#include <random>

#include "core/camera.h"
#include "core/map_geometry.h"
#include "core/tsai_camera.h"

namespace occmap::testing {

struct RandomRig {
  Camera camera;
  MapGeometry map;
};

// `width`, if given, fixes the image width (e.g. a multiple of 64, a SIMD strip's width).
inline RandomRig randomRig(std::mt19937_64& rng, int width = 0) {
  auto uniform = [&](double a, double b) {
    return std::uniform_real_distribution<double>(a, b)(rng);
  };
  auto integer = [&](int a, int b) { return std::uniform_int_distribution<int>(a, b)(rng); };
  // A camera 1-5 m up, looking at a floor point 1-6 m away, any lens from wide to narrow, with
  // barrel or pincushion distortion, and a small image so that the test runs many of them.
  const Eigen::Vector3d position(uniform(-3, 3), uniform(-3, 3), uniform(1, 5));
  const double angle = uniform(0, 6.283);
  const double reach = uniform(1, 6);
  const Eigen::Vector3d target(position.x() + reach * std::cos(angle),
                               position.y() + reach * std::sin(angle), 0.0);
  const Pose pose = poseLookingAt(position * 1000.0, target * 1000.0);
  TsaiParameters p;
  p.width = integer(48, 160);
  if (width > 0) p.width = width;
  p.height = integer(36, 120);
  p.ncx = p.nfx = p.width;
  p.dx = p.dy = p.dpx = p.dpy = uniform(0.02, 0.06);
  p.sx = uniform(0.95, 1.05);
  p.focal = uniform(0.5, 2.5) * p.dpx * p.width;  // horizontal field of view 23-90 degrees
  const double half_diagonal = 0.5 * p.dpx * std::hypot(p.width, p.height);
  p.kappa1 = uniform(-0.08, 0.1) / (half_diagonal * half_diagonal);
  p.cx = p.width / 2.0 + uniform(-3, 3);
  p.cy = p.height / 2.0 + uniform(-3, 3);
  p.setPose(pose);
  auto model = std::make_shared<TsaiCamera>(p);
  // The stream: the whole frame, half of it, or a crop.
  int stream_width = p.width, stream_height = p.height;
  ImageRegion region;
  switch (integer(0, 2)) {
    case 0:
      break;
    case 1:
      stream_width = p.width / 2;
      stream_height = p.height / 2;
      region = {0, 0, static_cast<double>(stream_width * 2),
                static_cast<double>(stream_height * 2)};
      break;
    default:
      region = {5, 3, static_cast<double>(p.width - 10), static_cast<double>(p.height - 8)};
      stream_width = p.width - 10;
      stream_height = p.height - 8;
      break;
  }
  MapGeometry map;
  map.cell_size_m = uniform(0.02, 0.2);
  map.width = integer(20, 90);
  map.height = integer(20, 90);
  map.origin_x_m = target.x() - uniform(0.2, 0.8) * map.width * map.cell_size_m;
  map.origin_y_m = target.y() - uniform(0.2, 0.8) * map.height * map.cell_size_m;
  return {Camera(model, LengthUnit::kMillimetre, stream_width, stream_height, region), map};
}

}  // namespace occmap::testing
