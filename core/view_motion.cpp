#include "core/view_motion.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "core/lighting_steps.h"

namespace occmap {
namespace {

// Each pyramid level halves the one below (2 x 2 means) while it stays at least this big: the
// coarsest level keeps enough texture to match (80 x 60 from 640 x 480).
constexpr int kCoarsestWidth = 64;
constexpr int kCoarsestHeight = 48;

void halve(ImageView from, Image& to) {
  for (int v = 0; v < to.height(); ++v) {
    const std::uint8_t* top = from.row(2 * v);
    const std::uint8_t* bottom = from.row(2 * v + 1);
    std::uint8_t* out = to.row(v);
    for (int u = 0; u < to.width(); ++u) {
      const int sum = top[2 * u] + top[2 * u + 1] + bottom[2 * u] + bottom[2 * u + 1];
      out[u] = static_cast<std::uint8_t>((sum + 2) / 4);
    }
  }
}

// The mean of the (2 radius + 1)^2 pixels around each pixel (fewer at the borders), in `out`.
void boxMean(ImageView from, int radius, std::vector<std::uint32_t>& column_sums,
             std::vector<std::uint8_t>& out) {
  const int width = from.width;
  const int height = from.height;
  for (int v = 0; v < height; ++v) {
    const int top = std::max(0, v - radius);
    const int bottom = std::min(height - 1, v + radius);
    for (int u = 0; u < width; ++u) {
      std::uint32_t sum = 0;
      for (int r = top; r <= bottom; ++r) sum += from.row(r)[u];
      column_sums[static_cast<std::size_t>(u)] = sum;
    }
    const auto rows = static_cast<std::uint32_t>(bottom - top + 1);
    std::uint32_t sum = 0;  // a running sum along the row
    for (int c = 0; c < std::min(width, radius); ++c)
      sum += column_sums[static_cast<std::size_t>(c)];
    for (int u = 0; u < width; ++u) {
      if (u + radius < width) sum += column_sums[static_cast<std::size_t>(u + radius)];
      if (u - radius - 1 >= 0) sum -= column_sums[static_cast<std::size_t>(u - radius - 1)];
      const int left = std::max(0, u - radius);
      const int right = std::min(width - 1, u + radius);
      const auto count = rows * static_cast<std::uint32_t>(right - left + 1);
      out[static_cast<std::size_t>(v) * static_cast<std::size_t>(width) +
          static_cast<std::size_t>(u)] = static_cast<std::uint8_t>((sum + count / 2) / count);
    }
  }
}

// The image's detail at the scale of texture and edges: its 3 x 3 mean less its 11 x 11 mean, as
// 128 + twice that, clamped (a difference of box filters, a band-pass). Light that changes slowly
// across the view and the smooth shading of floor and walls leave it, and so does most of the
// sensor's pixel-to-pixel noise; what stays correlates sharply at the true motion, where the
// images themselves correlate over tens of pixels and barely tell a shift of a few.
void keepDetail(ImageView from, Image& to, std::vector<std::uint32_t>& column_sums,
                std::vector<std::uint8_t>& fine, std::vector<std::uint8_t>& coarse) {
  boxMean(from, 1, column_sums, fine);
  boxMean(from, 5, column_sums, coarse);
  const auto width = static_cast<std::size_t>(from.width);
  for (int v = 0; v < from.height; ++v) {
    std::uint8_t* out = to.row(v);
    const std::size_t row = static_cast<std::size_t>(v) * width;
    for (std::size_t u = 0; u < width; ++u) {
      out[u] = static_cast<std::uint8_t>(
          std::clamp(128 + 2 * (fine[row + u] - coarse[row + u]), 0, 255));
    }
  }
}

// The vertex of the parabola through (-1, minus), (0, centre), (1, plus): the sub-pixel offset of a
// peak found at 0, within half a pixel.
double peakOffset(double minus, double centre, double plus) {
  const double curvature = minus - 2 * centre + plus;
  if (curvature >= 0) return 0;  // not a peak (flat or a valley): stay on the pixel
  return std::clamp(0.5 * (minus - plus) / curvature, -0.5, 0.5);
}

// Regions whose background varies less than this (standard deviation, grey levels) have too little
// texture to follow: a plain wall matches itself at every shift.
constexpr double kMinRegionDeviation = 2.0;

}  // namespace

double ViewMotion::largestDisplacementPx(int width, int height) const {
  const double cx = (width - 1) / 2.0;
  const double cy = (height - 1) / 2.0;
  const double theta = turn_deg * std::numbers::pi / 180;
  double largest = 0;
  for (const double x : {-cx, cx}) {
    for (const double y : {-cy, cy}) {
      largest = std::max(largest, std::hypot(shift_x_px - theta * y, shift_y_px + theta * x));
    }
  }
  return largest;
}

ViewMotionEstimator::ViewMotionEstimator(ImageView background)
    : column_sums_(static_cast<std::size_t>(std::max(0, background.width))),
      fine_(static_cast<std::size_t>(std::max(0, background.width)) *
            static_cast<std::size_t>(std::max(0, background.height))),
      coarse_(fine_.size()) {
  // The raw pyramid, then each level's detail; the live pyramids get their room now.
  std::vector<Image> raw;
  raw.emplace_back(background.width, background.height);
  for (int v = 0; v < background.height; ++v) {
    std::copy_n(background.row(v), background.width, raw.back().row(v));
  }
  while (raw.back().width() / 2 >= kCoarsestWidth && raw.back().height() / 2 >= kCoarsestHeight) {
    Image coarser(raw.back().width() / 2, raw.back().height() / 2);
    halve(raw.back().view(), coarser);
    raw.push_back(std::move(coarser));
  }
  for (const Image& level : raw) {
    background_.emplace_back(level.width(), level.height());
    keepDetail(level.view(), background_.back(), column_sums_, fine_, coarse_);
    live_.emplace_back(level.width(), level.height());
    live_raw_.emplace_back(level.width(), level.height());
  }
}

double ViewMotionEstimator::zncc(const Image& background, const Image& live, Window window, int dx,
                                 int dy) {
  // The part of the window whose moved pixels stay in the live image.
  const int x0 = std::max(window.x0, -dx);
  const int x1 = std::min(window.x1, live.width() - dx);
  const int y0 = std::max(window.y0, -dy);
  const int y1 = std::min(window.y1, live.height() - dy);
  const std::int64_t area =
      static_cast<std::int64_t>(window.x1 - window.x0) * (window.y1 - window.y0);
  if (x1 <= x0 || y1 <= y0 || 2 * static_cast<std::int64_t>(x1 - x0) * (y1 - y0) < area) return -1;
  lighting_steps::CorrelationSums sums;
  for (int y = y0; y < y1; ++y) {
    const lighting_steps::CorrelationSums row = lighting_steps::correlationSums(
        background.row(y) + x0, live.row(y + dy) + dx + x0, static_cast<std::size_t>(x1 - x0));
    sums.sum_b += row.sum_b;
    sums.sum_l += row.sum_l;
    sums.sum_bb += row.sum_bb;
    sums.sum_ll += row.sum_ll;
    sums.sum_bl += row.sum_bl;
  }
  const double n = static_cast<double>(x1 - x0) * (y1 - y0);
  const double b = static_cast<double>(sums.sum_b);
  const double l = static_cast<double>(sums.sum_l);
  const double covariance = n * static_cast<double>(sums.sum_bl) - b * l;
  const double var_b = n * static_cast<double>(sums.sum_bb) - b * b;
  const double var_l = n * static_cast<double>(sums.sum_ll) - l * l;
  const double min_var = n * n * kMinRegionDeviation * kMinRegionDeviation;
  if (var_b < min_var || var_l < min_var) return -1;  // nothing to match: flat, dark or covered
  return covariance / std::sqrt(var_b * var_l);
}

void ViewMotionEstimator::search(const Image& background, const Image& live, Window window, int cx,
                                 int cy, int radius, int& best_x, int& best_y, double& best_match) {
  best_x = cx;
  best_y = cy;
  best_match = -2;
  for (int dy = cy - radius; dy <= cy + radius; ++dy) {
    for (int dx = cx - radius; dx <= cx + radius; ++dx) {
      const double match = zncc(background, live, window, dx, dy);
      // Ties go to the smaller motion: a plain view should not look moved.
      if (match > best_match || (match == best_match && std::abs(dx) + std::abs(dy) <
                                                            std::abs(best_x) + std::abs(best_y))) {
        best_match = match;
        best_x = dx;
        best_y = dy;
      }
    }
  }
}

ViewMotion ViewMotionEstimator::estimate(ImageView live) {
  ViewMotion motion;
  const Image& full = background_.front();
  const int width = full.width();
  const int height = full.height();
  if (live.width != width || live.height != height || width < 32 || height < 24) return motion;
  keepDetail(live, live_.front(), column_sums_, fine_, coarse_);
  for (std::size_t level = 1; level < live_.size(); ++level) {
    halve(level == 1 ? live : live_raw_[level - 1].view(), live_raw_[level]);
    keepDetail(live_raw_[level].view(), live_[level], column_sums_, fine_, coarse_);
  }

  // Coarse to fine over the whole image: every shift up to a fifth of the coarsest level's smaller
  // side (about 10 degrees for a lens of 60 degrees), then +-1 on each finer level.
  const std::size_t coarsest = background_.size() - 1;
  int best_x = 0, best_y = 0;
  double best = -2;
  for (std::size_t level = coarsest + 1; level-- > 0;) {
    const Image& b = background_[level];
    const Window whole{0, 0, b.width(), b.height()};
    if (level == coarsest) {
      search(b, live_[level], whole, 0, 0, std::min(b.width(), b.height()) / 5, best_x, best_y,
             best);
    } else {
      search(b, live_[level], whole, 2 * best_x, 2 * best_y, 1, best_x, best_y, best);
    }
  }
  motion.shift_x_px = best_x;
  motion.shift_y_px = best_y;

  // Then each region on its own, in two rounds. First 3 x 3 regions from the whole image's shift:
  // +-4 on level 1 (+-8 pixels, room for a turn's displacement) and +-1 on level 0. Then 5 x 5
  // smaller ones (a turn about the axis smears a region's match less), +-2 on level 0 around what
  // the first round's fit predicts at each. Each to its sub-pixel peak; only those that match.
  const std::size_t region_level = std::min<std::size_t>(1, coarsest);
  const int scale = 1 << region_level;
  const Image& level0 = live_.front();
  const auto follow = [&](int across, bool first_round) {
    int regions = 0;
    double match_sum = 0;
    double unmoved_sum = 0;
    for (int ry = 0; ry < across; ++ry) {
      for (int rx = 0; rx < across; ++rx) {
        const Window region{rx * width / across, ry * height / across, (rx + 1) * width / across,
                            (ry + 1) * height / across};
        const Eigen::Vector2d at((region.x0 + region.x1 - 1) / 2.0,
                                 (region.y0 + region.y1 - 1) / 2.0);
        int x = 0, y = 0;
        double match = -2;
        if (first_round) {
          const Window coarse{region.x0 / scale, region.y0 / scale, region.x1 / scale,
                              region.y1 / scale};
          search(background_[region_level], live_[region_level], coarse,
                 static_cast<int>(std::lround(static_cast<double>(best_x) / scale)),
                 static_cast<int>(std::lround(static_cast<double>(best_y) / scale)), 4, x, y,
                 match);
          search(full, level0, region, scale * x, scale * y, 1, x, y, match);
        } else {
          const Eigen::Vector2d predicted = motion.predictedShift(at, width, height);
          search(full, level0, region, static_cast<int>(std::lround(predicted.x())),
                 static_cast<int>(std::lround(predicted.y())), 2, x, y, match);
        }
        if (match < kMinMatch) continue;
        const double sub_x = peakOffset(zncc(full, level0, region, x - 1, y), match,
                                        zncc(full, level0, region, x + 1, y));
        const double sub_y = peakOffset(zncc(full, level0, region, x, y - 1), match,
                                        zncc(full, level0, region, x, y + 1));
        // A region's match follows its texture, which need not lie evenly about its centre (a
        // textured floor under a plain wall): its shift is that of its texture's centre, the
        // place a turn's shift is predicted at.
        motion.region[static_cast<std::size_t>(regions)] = {textureCentre(full, region, x, y),
                                                            {x + sub_x, y + sub_y}};
        ++regions;
        match_sum += match;
        unmoved_sum += std::max(0.0, zncc(full, level0, region, 0, 0));
      }
    }
    motion.regions = regions;
    motion.match = regions > 0 ? match_sum / regions : best;
    motion.match_unmoved = regions > 0 ? unmoved_sum / regions : 0;
    fitImageMotion(motion, width, height);
  };
  follow(3, true);
  if (motion.regions >= 3) follow(5, false);
  motion.moved = motion.regions >= 3 && motion.match >= kMinMatch &&
                 1 - motion.match <= kMostMismatchLeft * (1 - motion.match_unmoved) &&
                 motion.largestDisplacementPx(width, height) >= kMinDisplacementPx;
  return motion;
}

Eigen::Vector2d ViewMotionEstimator::textureCentre(const Image& background, Window window, int dx,
                                                   int dy) {
  const int x0 = std::max(window.x0, -dx);
  const int x1 = std::min(window.x1, background.width() - dx);
  const int y0 = std::max(window.y0, -dy);
  const int y1 = std::min(window.y1, background.height() - dy);
  double weight = 0;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (int y = y0; y < y1; ++y) {
    const std::uint8_t* row = background.row(y);
    for (int x = x0; x < x1; ++x) {
      const double energy = (row[x] - 128) * (row[x] - 128);
      weight += energy;
      sum += energy * Eigen::Vector2d(x, y);
    }
  }
  if (weight == 0) return {(window.x0 + window.x1 - 1) / 2.0, (window.y0 + window.y1 - 1) / 2.0};
  return sum / weight;
}

Eigen::Vector2d ViewMotion::predictedShift(const Eigen::Vector2d& at, int width, int height) const {
  const double theta = turn_deg * std::numbers::pi / 180;
  const Eigen::Vector2d p = at - Eigen::Vector2d((width - 1) / 2.0, (height - 1) / 2.0);
  return {shift_x_px - theta * p.y(), shift_y_px + theta * p.x()};
}

void ViewMotionEstimator::fitImageMotion(ViewMotion& motion, int width, int height) {
  // Translation and turn about the centre by least squares: shift_i = t + theta (-(y - cy), x -
  // cx).
  const int regions = motion.regions;
  const Eigen::Vector2d centre((width - 1) / 2.0, (height - 1) / 2.0);
  if (regions >= 3) {
    // The normal equations, in fixed-size matrices (nothing allocated).
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Vector3d right = Eigen::Vector3d::Zero();
    for (int i = 0; i < regions; ++i) {
      const auto& [at, shift] = motion.region[static_cast<std::size_t>(i)];
      const Eigen::Vector2d p = at - centre;
      const Eigen::Vector3d along_x(1, 0, -p.y());
      const Eigen::Vector3d along_y(0, 1, p.x());
      normal += along_x * along_x.transpose() + along_y * along_y.transpose();
      right += along_x * shift.x() + along_y * shift.y();
    }
    const Eigen::Vector3d fit = normal.ldlt().solve(right);
    motion.shift_x_px = fit.x();
    motion.shift_y_px = fit.y();
    motion.turn_deg = fit.z() * 180 / std::numbers::pi;
    double squares = 0;
    for (int i = 0; i < regions; ++i) {
      const auto& [at, shift] = motion.region[static_cast<std::size_t>(i)];
      squares += (motion.predictedShift(at, width, height) - shift).squaredNorm();
    }
    motion.residual_px = std::sqrt(squares / regions);
  } else if (regions > 0) {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (int i = 0; i < regions; ++i) mean += motion.region[static_cast<std::size_t>(i)].shift;
    mean /= regions;
    motion.shift_x_px = mean.x();
    motion.shift_y_px = mean.y();
    motion.turn_deg = 0;
  }
}

double CameraTurn::degrees() const { return turn.norm() * 180 / std::numbers::pi; }

CameraTurn cameraTurn(const Camera& camera, const ViewMotion& motion) {
  CameraTurn result;
  if (motion.regions < 3) return result;
  const Eigen::Matrix3d& rotation = camera.model().pose().rotation;  // world to camera
  // Each region's ray before (at its place in the background) and after (where its content went),
  // in camera coordinates.
  std::array<Eigen::Vector3d, 25> before;
  std::array<Eigen::Vector3d, 25> after;
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < static_cast<std::size_t>(motion.regions); ++i) {
    const auto from = camera.streamToRay(motion.region[i].at);
    const auto to = camera.streamToRay(motion.region[i].at + motion.region[i].shift);
    if (!from || !to) return result;
    before[i] = (rotation * from->direction).normalized();
    after[i] = (rotation * to->direction).normalized();
    h += before[i] * after[i].transpose();
  }
  // Kabsch: the rotation Q minimising the sum of |Q before - after|^2.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1 : 1;
  const Eigen::Matrix3d q = svd.matrixV() * d * svd.matrixU().transpose();
  const Eigen::AngleAxisd angle_axis(q);
  result.turn = angle_axis.axis() * angle_axis.angle();
  result.found = true;
  // The residual in pixels: where the turned camera sees each region's content, against where it
  // was found. A world point X is seen after the turn where the old camera sees
  // C + R^T Q R (X - C).
  const Eigen::Vector3d centre = camera.centreMetres();
  const Eigen::Matrix3d world_turn = rotation.transpose() * q * rotation;
  double squares = 0;
  for (std::size_t i = 0; i < static_cast<std::size_t>(motion.regions); ++i) {
    const Eigen::Vector3d seen = centre + world_turn * (rotation.transpose() * before[i]);
    const auto predicted = camera.worldToStream(seen);
    if (!predicted) return CameraTurn{};
    squares += (*predicted - (motion.region[i].at + motion.region[i].shift)).squaredNorm();
  }
  result.residual_px = std::sqrt(squares / motion.regions);
  return result;
}

}  // namespace occmap
