#include "core/repose.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace occmap {

ReposedCamera reposeCamera(const Camera& camera, const Eigen::Vector3d& turn, ImageView background,
                           ImageView floor_mask, const MapGeometry& map, double column_height_m) {
  ReposedCamera out{turn,
                    camera.turned(turn),
                    Image(background.width, background.height),
                    Image(background.width, background.height),
                    {}};
  const int width = background.width;
  const int height = background.height;
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      // The turned camera's ray through this pixel, seen by the old camera: where the old
      // background had what this pixel now sees (the centre is the same, so any point on the ray
      // will do).
      const auto ray = out.camera.streamToRay(Eigen::Vector2d(u, v));
      if (!ray) continue;
      const auto old_pixel = camera.worldToStream(ray->origin + ray->direction);
      if (!old_pixel) continue;
      const double x = old_pixel->x();
      const double y = old_pixel->y();
      if (!(x >= 0 && y >= 0 && x <= width - 1 && y <= height - 1)) continue;
      const int x0 = std::min(static_cast<int>(x), width - 2);
      const int y0 = std::min(static_cast<int>(y), height - 2);
      const double fx = x - x0;
      const double fy = y - y0;
      const auto at = [](ImageView image, int uu, int vv) -> double { return image.at(uu, vv); };
      const double grey =
          (1 - fy) * ((1 - fx) * at(background, x0, y0) + fx * at(background, x0 + 1, y0)) +
          fy * ((1 - fx) * at(background, x0, y0 + 1) + fx * at(background, x0 + 1, y0 + 1));
      out.background.at(u, v) = static_cast<std::uint8_t>(std::lround(grey));
      // Floor only where all four pixels it comes from were: an edge of the mask stays inside.
      // (No mask: every pixel the old view had.)
      const bool floor = floor_mask.empty() ||
                         (floor_mask.at(x0, y0) != 0 && floor_mask.at(x0 + 1, y0) != 0 &&
                          floor_mask.at(x0, y0 + 1) != 0 && floor_mask.at(x0 + 1, y0 + 1) != 0);
      out.floor_mask.at(u, v) = floor ? 255 : 0;
    }
  }
  out.table = buildCarveTable(out.camera, map, column_height_m, out.floor_mask.view());
  return out;
}

std::optional<Eigen::Vector3d> ReposePolicy::check(std::int64_t time_us, bool moved,
                                                   const Eigen::Vector3d& turn,
                                                   double residual_px) {
  if (!moved || residual_px > kMaxResidualPx || turn.isZero(0)) {
    first_us_.reset();
    return std::nullopt;
  }
  if (!first_us_ || (turn - first_turn_).norm() >= kSameTurnRad || time_us < *first_us_) {
    first_us_ = time_us;  // a new run starts here
    first_turn_ = turn;
    return std::nullopt;
  }
  if (time_us - *first_us_ < kSteadyUs) return std::nullopt;
  first_us_.reset();
  return turn;
}

}  // namespace occmap
