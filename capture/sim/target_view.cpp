#include "capture/sim/target_view.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

#include <Eigen/Geometry>

namespace occmap::sim {
namespace {

Eigen::Matrix3d rodrigues(const Eigen::Vector3d& rvec) {
  const double angle = rvec.norm();
  if (angle == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, rvec / angle).toRotationMatrix();
}

// The texture's grey level at paper point p (metres), interpolated between its four nearest
// pixels: a pixel's value belongs to its centre.
double bilinearShade(const cv::Mat& texture, double width_m, double height_m,
                     const Eigen::Vector2d& p) {
  const double x = std::clamp(p.x() / width_m * texture.cols - 0.5, 0.0, texture.cols - 1.0);
  const double y = std::clamp(p.y() / height_m * texture.rows - 0.5, 0.0, texture.rows - 1.0);
  const int x0 = std::min(static_cast<int>(x), texture.cols - 2);
  const int y0 = std::min(static_cast<int>(y), texture.rows - 2);
  const double fx = x - x0;
  const double fy = y - y0;
  const auto at = [&](int row, int column) {
    return static_cast<double>(texture.at<std::uint8_t>(row, column));
  };
  return (1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x0 + 1)) +
         fy * ((1 - fx) * at(y0 + 1, x0) + fx * at(y0 + 1, x0 + 1));
}

// Points along the paper's outline, for its projected bounds: with lens distortion its straight
// edges bow, so the corners alone could miss a bulge.
std::vector<Eigen::Vector2d> outline(double width_m, double height_m) {
  constexpr int kPerEdge = 16;
  std::vector<Eigen::Vector2d> points;
  for (int k = 0; k < kPerEdge; ++k) {
    const double s = static_cast<double>(k) / kPerEdge;
    points.emplace_back(s * width_m, 0.0);
    points.emplace_back(width_m, s * height_m);
    points.emplace_back((1 - s) * width_m, height_m);
    points.emplace_back(0.0, (1 - s) * height_m);
  }
  return points;
}

}  // namespace

Eigen::Vector3d targetPointInWorld(const Camera& camera, const TargetPose& pose,
                                   const Eigen::Vector2d& paper_m) {
  const Eigen::Vector3d in_camera =
      rodrigues(pose.rvec) * Eigen::Vector3d(paper_m.x(), paper_m.y(), 0.0) + pose.tvec;
  // Xc = R Xw + t, so Xw = R^T Xc + the camera's centre (rotations carry no unit).
  return camera.model().pose().rotation.transpose() * in_camera + camera.centreMetres();
}

Image renderTargetView(const Renderer& empty_view, const cv::Mat& texture, double width_m,
                       double height_m, const TargetPose& pose, std::uint64_t noise_seed) {
  const Camera& camera = empty_view.camera();
  const int width = camera.streamWidth();
  const int height = camera.streamHeight();
  Image out = empty_view.background();
  const Eigen::Matrix3d to_camera = camera.model().pose().rotation;
  const Eigen::Matrix3d board = rodrigues(pose.rvec);
  const Eigen::Vector3d normal = board.col(2);
  const double plane_offset = normal.dot(pose.tvec);

  // Only the pixels the paper can cover; all of them if part of it has no image.
  double u_min = std::numeric_limits<double>::infinity(), v_min = u_min;
  double u_max = -u_min, v_max = -u_min;
  for (const Eigen::Vector2d& p : outline(width_m, height_m)) {
    const std::optional<Eigen::Vector2d> s =
        camera.worldToStream(targetPointInWorld(camera, pose, p));
    if (!s) {
      u_min = v_min = 0;
      u_max = width;
      v_max = height;
      break;
    }
    u_min = std::min(u_min, s->x());
    u_max = std::max(u_max, s->x());
    v_min = std::min(v_min, s->y());
    v_max = std::max(v_max, s->y());
  }
  constexpr double kMargin = 2.0;
  const int u0 = std::max(0, static_cast<int>(std::floor(u_min - kMargin)));
  const int v0 = std::max(0, static_cast<int>(std::floor(v_min - kMargin)));
  const int u1 = std::min(width - 1, static_cast<int>(std::ceil(u_max + kMargin)));
  const int v1 = std::min(height - 1, static_cast<int>(std::ceil(v_max + kMargin)));

  // A camera integrates light over its pixel: 4 x 4 rays a pixel, so that the board's edges and
  // corners land where a real camera would put them, to a small fraction of a pixel.
  constexpr int kSamples = 4;
  constexpr double kStep = 1.0 / kSamples;
  for (int v = v0; v <= v1; ++v) {
    for (int u = u0; u <= u1; ++u) {
      const double behind = out.at(u, v);
      double sum = 0.0;
      bool seen = false;
      for (int a = 0; a < kSamples; ++a) {
        for (int b = 0; b < kSamples; ++b) {
          const std::optional<Ray> ray =
              camera.streamToRay({u + (b + 0.5) * kStep - 0.5, v + (a + 0.5) * kStep - 0.5});
          std::optional<double> shade;
          if (ray) {
            const Eigen::Vector3d direction = to_camera * ray->direction;
            const double along = normal.dot(direction);
            const double s = along != 0.0 ? plane_offset / along : -1.0;
            if (s > 0.0) {
              const Eigen::Vector2d paper =
                  (board.transpose() * (s * direction - pose.tvec)).head<2>();
              if (paper.x() >= 0 && paper.y() >= 0 && paper.x() <= width_m &&
                  paper.y() <= height_m) {
                shade = bilinearShade(texture, width_m, height_m, paper);
              }
            }
          }
          seen = seen || shade.has_value();
          sum += shade.value_or(behind);
        }
      }
      if (seen) {
        out.at(u, v) = static_cast<std::uint8_t>(
            std::clamp(std::lround(sum / (kSamples * kSamples)), 0L, 255L));
      }
    }
  }
  addSensorNoise(noise_seed, out);
  return out;
}

std::vector<TargetPose> targetPosesFor(const Camera& camera, double width_m, double height_m,
                                       int count, bool partly_in_view) {
  // A ChArUco board counts partly seen, so it is held out past the picture's edges too; a
  // chessboard must be seen whole.
  const double least_in_view = partly_in_view ? 0.7 : 1.0;
  const double width = camera.streamWidth();
  const double height = camera.streamHeight();
  const Eigen::Matrix3d to_camera = camera.model().pose().rotation;
  // Where the target's centre is aimed (fractions of the image), how it is tilted (degrees about
  // the camera's x and y axes, and a little about its own normal) and how much of the image it
  // fills, in cycles of different lengths so that the poses mix them.
  // As far out as the target goes whole: the corners and edges are where a lens's distortion
  // shows, and `occmap calibrate intrinsics` wants half the image covered. Nearer a corner it is
  // held further away (it fills less), so that it reaches into the corner.
  struct Place {
    double u, v;  // where its centre is aimed, as fractions of the image
    double fill;  // the share of the image it fills
  };
  constexpr std::array<Place, 9> kPlaces = {{{0.5, 0.5, 0.45},
                                             {0.1, 0.1, 0.15},
                                             {0.9, 0.9, 0.15},
                                             {0.9, 0.1, 0.15},
                                             {0.1, 0.9, 0.15},
                                             {0.5, 0.12, 0.25},
                                             {0.12, 0.5, 0.25},
                                             {0.5, 0.88, 0.25},
                                             {0.88, 0.5, 0.25}}};
  constexpr std::array<std::array<double, 3>, 8> kTilts = {{{0, 0, 0},
                                                            {30, 0, 5},
                                                            {0, -30, -5},
                                                            {-25, 25, 10},
                                                            {25, 25, -10},
                                                            {-35, 0, 0},
                                                            {0, 35, 5},
                                                            {20, -25, -5}}};
  constexpr double kMarginFraction = 0.01;
  const double margin = kMarginFraction * width;
  const auto degrees = [](double d) { return d * std::numbers::pi / 180.0; };
  const std::vector<Eigen::Vector2d> edge = outline(width_m, height_m);
  const Eigen::Vector2d middle(width_m / 2, height_m / 2);

  std::vector<TargetPose> poses;
  for (int k = 0; k < count; ++k) {
    const auto index = static_cast<std::size_t>(k);
    const Place& place = kPlaces[index % kPlaces.size()];
    const std::array<double, 3>& tilt = kTilts[index % kTilts.size()];
    Eigen::Vector2d aim(place.u * width, place.v * height);
    double fill = place.fill;
    const Eigen::Matrix3d board = (Eigen::AngleAxisd(degrees(tilt[0]), Eigen::Vector3d::UnitX()) *
                                   Eigen::AngleAxisd(degrees(tilt[1]), Eigen::Vector3d::UnitY()) *
                                   Eigen::AngleAxisd(degrees(tilt[2]), Eigen::Vector3d::UnitZ()))
                                      .toRotationMatrix();
    const Eigen::AngleAxisd turn(board);
    std::optional<TargetPose> held;
    // A person moves the target in towards the image's middle, and back, until it is all in view.
    for (int attempt = 0; attempt < 120 && !held; ++attempt) {
      const std::optional<Ray> ray = camera.streamToRay(aim);
      if (!ray) break;
      Eigen::Vector3d direction = to_camera * ray->direction;
      direction /= direction.z();
      double depth = 1.0;
      TargetPose pose;
      pose.rvec = turn.angle() * turn.axis();
      bool imaged = true;
      std::vector<Eigen::Vector2d> corners;
      for (int step = 0; step < 8 && imaged; ++step) {
        pose.tvec = depth * direction - board * Eigen::Vector3d(middle.x(), middle.y(), 0.0);
        corners.clear();
        for (const Eigen::Vector2d& p :
             {Eigen::Vector2d(0, 0), Eigen::Vector2d(width_m, 0),
              Eigen::Vector2d(width_m, height_m), Eigen::Vector2d(0, height_m)}) {
          const std::optional<Eigen::Vector2d> s =
              camera.worldToStream(targetPointInWorld(camera, pose, p));
          if (!s) {
            imaged = false;
            break;
          }
          corners.push_back(*s);
        }
        if (!imaged) break;
        double area = 0.0;  // the shoelace formula
        for (std::size_t c = 0; c < 4; ++c) {
          const Eigen::Vector2d& a = corners[c];
          const Eigen::Vector2d& b = corners[(c + 1) % 4];
          area += a.x() * b.y() - b.x() * a.y();
        }
        depth *= std::sqrt(std::abs(area) / 2 / (fill * width * height));
      }
      // The share of the target's outline in the picture, within the margin.
      std::size_t in_view = 0;
      for (const Eigen::Vector2d& p : edge) {
        if (!imaged) break;
        const std::optional<Eigen::Vector2d> s =
            camera.worldToStream(targetPointInWorld(camera, pose, p));
        in_view += s && s->x() >= margin && s->y() >= margin && s->x() <= width - 1 - margin &&
                           s->y() <= height - 1 - margin
                       ? 1
                       : 0;
      }
      const bool inside = imaged && static_cast<double>(in_view) >=
                                        least_in_view * static_cast<double>(edge.size());
      if (inside) {
        held = pose;
      } else {
        aim += 0.05 * (Eigen::Vector2d(width / 2, height / 2) - aim);
        if (attempt % 4 == 3) fill *= 0.95;
      }
    }
    if (held) poses.push_back(*held);
  }
  return poses;
}

}  // namespace occmap::sim
