#include "core/local_light.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "core/fusion_kernel.h"
#include "core/lighting_steps.h"

namespace occmap {
namespace {

// A local light between a fifth and five times the frame's (after the global gain): beyond, no
// lamp or sun is that much brighter or darker than its surroundings on a floor a camera can use.
constexpr double kLowestGain = 0.2;
constexpr double kHighestGain = 5.0;

bool tileChanged(const std::uint8_t* changed_tiles, std::size_t tile) {
  std::uint64_t word;
  std::memcpy(&word, changed_tiles + tile * 8, sizeof word);
  return word != 0;
}

void clearTile(std::uint8_t* changed_tiles, std::size_t tile) {
  std::memset(changed_tiles + tile * 8, 0, 8);
}

}  // namespace

LocalLight::LocalLight(int width, int height)
    : width_(width),
      height_(height),
      across_(tilesAcross(width)),
      down_(tilesDown(height)),
      state_(across_ * down_, kUnchanged) {
  queue_.reserve(across_ * down_);
}

bool LocalLight::unchangedUnder(ImageView frame, ImageView background, std::size_t tile,
                                const Light& light, int threshold, int saturated) const {
  const auto [u0, v0, u1, v1] = pixelsOf(tile);
  const auto limit = static_cast<float>(threshold);
  for (int v = v0; v < v1; ++v) {
    const std::uint8_t* l = frame.row(v);
    const std::uint8_t* b = background.row(v);
    const float row_gain = light.gain + light.per_v * static_cast<float>(v - v0 - 4);
    for (int u = u0; u < u1; ++u) {
      const float expected =
          (row_gain + light.per_u * static_cast<float>(u - u0 - 4)) * static_cast<float>(b[u]);
      if (l[u] >= saturated) {
        if (expected + limit <= static_cast<float>(saturated)) return false;
      } else if (std::abs(static_cast<float>(l[u]) - expected) >= limit) {
        return false;
      }
    }
  }
  return true;
}

std::optional<LocalLight::Light> LocalLight::slopedSeed(ImageView frame, ImageView background,
                                                        std::size_t tile, double noise2,
                                                        int threshold, int saturated) const {
  const auto [u0, v0, u1, v1] = pixelsOf(tile);
  // Least squares of l = b (g + gu du + gv dv) over the measured pixels, du and dv from the
  // tile's middle: three regressors b, b du, b dv.
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Vector3d right = Eigen::Vector3d::Zero();
  double sum_ll = 0.0;
  // And the background's own plane, b = p + pu du + pv dv: a flat object over a background that is
  // only a ramp fits a sloped gain (l / b is then about linear too), so such a fit says something
  // only of the texture a plane leaves.
  Eigen::Matrix3d plane_normal = Eigen::Matrix3d::Zero();
  Eigen::Vector3d plane_right = Eigen::Vector3d::Zero();
  double sum_bb = 0.0;
  double n = 0.0;
  for (int v = v0; v < v1; ++v) {
    const std::uint8_t* l = frame.row(v);
    const std::uint8_t* b = background.row(v);
    for (int u = u0; u < u1; ++u) {
      if (l[u] >= saturated) continue;
      n += 1.0;
      const double bb = b[u];
      const Eigen::Vector3d x(bb, bb * (u - u0 - 4), bb * (v - v0 - 4));
      normal.noalias() += x * x.transpose();
      right += x * static_cast<double>(l[u]);
      sum_ll += static_cast<double>(l[u]) * l[u];
      const Eigen::Vector3d place(1.0, u - u0 - 4, v - v0 - 4);
      plane_normal.noalias() += place * place.transpose();
      plane_right += place * bb;
      sum_bb += bb * bb;
    }
  }
  const Eigen::LDLT<Eigen::Matrix3d> solver(normal);
  if (solver.info() != Eigen::Success || !solver.isPositive()) return std::nullopt;
  const Eigen::Vector3d fit = solver.solve(right);
  const double residual = sum_ll - fit.dot(right);
  const Eigen::LDLT<Eigen::Matrix3d> plane_solver(plane_normal);
  if (plane_solver.info() != Eigen::Success || !plane_solver.isPositive()) return std::nullopt;
  const double texture = sum_bb - plane_solver.solve(plane_right).dot(plane_right);
  // The seed rules, as for one gain (explain()).
  if (fit.x() * fit.x() * texture < kTexture * n * noise2 || residual > kResidual * n * noise2) {
    return std::nullopt;
  }
  // The gain at every corner within the bounds.
  for (const double du : {-4.0, 3.0}) {
    for (const double dv : {-4.0, 3.0}) {
      const double corner = fit.x() + fit.y() * du + fit.z() * dv;
      if (!(corner >= kLowestGain && corner <= kHighestGain)) return std::nullopt;
    }
  }
  const Light light{static_cast<float>(fit.x()), static_cast<float>(fit.y()),
                    static_cast<float>(fit.z())};
  if (!unchangedUnder(frame, background, tile, light, threshold, saturated)) return std::nullopt;
  return light;
}

std::size_t LocalLight::explain(ImageView frame, ImageView background, ImageView captured,
                                double noise, int threshold, int saturated,
                                std::uint8_t* changed_tiles) {
  const double noise2 = std::max(1.0, noise * noise);
  queue_.clear();
  tally_ = {};
  // The textured tiles that one gain explains: the seeds.
  for (std::size_t tile = 0; tile < state_.size(); ++tile) {
    if (!tileChanged(changed_tiles, tile)) {
      state_[tile] = kUnchanged;
      continue;
    }
    // The light as it was when the background was captured, which the drift may have moved away
    // from (a lamp learnt while it was on and now off again): nothing stands there either.
    ++tally_.changed;
    if (!captured.empty() &&
        unchangedUnder(frame, captured, tile, Light{1.0f}, threshold, saturated)) {
      ++tally_.as_captured;
      state_[tile] = kCaptured;
      queue_.push_back(
          {static_cast<std::uint32_t>(tile), 1.0f, kReach});  // its gain is not this light's
      continue;
    }
    state_[tile] = kChanged;
    const auto [u0, v0, u1, v1] = pixelsOf(tile);
    const auto [count, sum_b, sum_bb, sum_lb, sum_ll] =
        lighting_steps::tileSums(frame.row(v0) + u0, frame.stride, background.row(v0) + u0,
                                 background.stride, u1 - u0, v1 - v0, saturated);
    // At least a quarter of the tile measured (16 pixels): the rest clipped, which the pixel
    // test below holds to where the gain says the sensor clips. Half, as it was, left a patch of
    // sun that clips the brighter boards changed wherever the darker ones were few.
    if (sum_bb == 0 || 4 * count < static_cast<std::uint32_t>((u1 - u0) * (v1 - v0))) {
      ++tally_.clipped;
      continue;
    }
    // The tests of the gain g = lb / bb multiplied out by bb (and n), without a division: most
    // changed tiles fail one, and each division would wait some 20 cycles.
    const double n = count;
    const double lb = sum_lb;
    const double bb = sum_bb;
    if (lb < kLowestGain * bb || lb > kHighestGain * bb) {
      ++tally_.out_of_range;
      continue;
    }
    // g² x texture (bb - b² / n) against kTexture n sigma², times n bb².
    const double b = sum_b;
    if (lb * lb * (n * bb - b * b) < kTexture * n * n * noise2 * bb * bb) {  // too flat to tell
      ++tally_.flat;
      continue;
    }
    // The misfit ll - g lb against kResidual n sigma², times bb.
    if (static_cast<double>(sum_ll) * bb - lb * lb > kResidual * n * noise2 * bb) {
      // Not one gain: an object, or light that changes across the tile (a lamp's soft edge, a
      // shadow's). The walk below tries a gain that changes across it, next to light found.
      state_[tile] = kMisfit;
      ++tally_.misfit;
      continue;
    }
    const Light light{static_cast<float>(lb / bb)};
    if (!unchangedUnder(frame, background, tile, light, threshold, saturated)) {
      ++tally_.pixel;
      continue;
    }
    ++tally_.seeds;
    state_[tile] = kLit;
    queue_.push_back({static_cast<std::uint32_t>(tile), light.gain, 0});
  }
  // Then their gains spread to changed neighbours that are unchanged under them, tile by tile, in
  // order of distance (a breadth-first walk), as far as kReach. A neighbour that one gain did not
  // fit may be a seed of a light that changes across it (slopedSeed): light goes on from light, so
  // only tiles next to light found are tried (an object's edge, next to a seed, is tried and fails
  // on its texture or its fit).
  for (std::size_t next = 0; next < queue_.size(); ++next) {
    const Seed seed = queue_[next];
    const std::size_t column = seed.tile % across_;
    const std::size_t row = seed.tile / across_;
    const std::size_t neighbours[4] = {
        column > 0 ? seed.tile - 1 : state_.size(),
        column + 1 < across_ ? seed.tile + 1 : state_.size(),
        row > 0 ? seed.tile - across_ : state_.size(),
        row + 1 < down_ ? seed.tile + across_ : state_.size(),
    };
    for (const std::size_t tile : neighbours) {
      if (tile >= state_.size() || (state_[tile] != kChanged && state_[tile] != kMisfit)) continue;
      if (seed.steps < kReach &&
          unchangedUnder(frame, background, tile, Light{seed.gain}, threshold, saturated)) {
        state_[tile] = kLit;
        ++tally_.reached;
        queue_.push_back({static_cast<std::uint32_t>(tile), seed.gain, seed.steps + 1});
        continue;
      }
      if (state_[tile] != kMisfit) continue;
      state_[tile] = kChanged;  // tried once
      if (const std::optional<Light> light =
              slopedSeed(frame, background, tile, noise2, threshold, saturated)) {
        state_[tile] = kLit;
        --tally_.misfit;
        ++tally_.seeds;
        ++tally_.sloped;
        queue_.push_back({static_cast<std::uint32_t>(tile), light->gain, 0});
      }
    }
  }
  for (const Seed& seed : queue_) clearTile(changed_tiles, seed.tile);
  return queue_.size();
}

}  // namespace occmap
