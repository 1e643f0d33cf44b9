#include "core/local_light.h"

#include <algorithm>
#include <cmath>
#include <cstring>

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

bool LocalLight::unchangedUnder(ImageView frame, ImageView background, std::size_t tile, float gain,
                                int threshold, int saturated) const {
  const int u0 = static_cast<int>(tile % across_) * 8;
  const int v0 = static_cast<int>(tile / across_) * 8;
  const int u1 = std::min(width_, u0 + 8);
  const int v1 = std::min(height_, v0 + 8);
  const auto limit = static_cast<float>(threshold);
  for (int v = v0; v < v1; ++v) {
    const std::uint8_t* l = frame.row(v);
    const std::uint8_t* b = background.row(v);
    for (int u = u0; u < u1; ++u) {
      const float expected = gain * static_cast<float>(b[u]);
      if (l[u] >= saturated) {
        if (expected + limit <= static_cast<float>(saturated)) return false;
      } else if (std::abs(static_cast<float>(l[u]) - expected) >= limit) {
        return false;
      }
    }
  }
  return true;
}

std::size_t LocalLight::explain(ImageView frame, ImageView background, ImageView captured,
                                double noise, int threshold, int saturated,
                                std::uint8_t* changed_tiles) {
  const double noise2 = std::max(1.0, noise * noise);
  queue_.clear();
  // The textured tiles that one gain explains: the seeds.
  for (std::size_t tile = 0; tile < state_.size(); ++tile) {
    if (!tileChanged(changed_tiles, tile)) {
      state_[tile] = kUnchanged;
      continue;
    }
    // The light as it was when the background was captured, which the drift may have moved away
    // from (a lamp learnt while it was on and now off again): nothing stands there either.
    if (!captured.empty() && unchangedUnder(frame, captured, tile, 1.0f, threshold, saturated)) {
      state_[tile] = kExplained;
      queue_.push_back(
          {static_cast<std::uint32_t>(tile), 1.0f, kReach});  // its gain is not this light's
      continue;
    }
    state_[tile] = kChanged;
    const int u0 = static_cast<int>(tile % across_) * 8;
    const int v0 = static_cast<int>(tile / across_) * 8;
    const int u1 = std::min(width_, u0 + 8);
    const int v1 = std::min(height_, v0 + 8);
    const auto [count, sum_b, sum_bb, sum_lb, sum_ll] =
        lighting_steps::tileSums(frame.row(v0) + u0, frame.stride, background.row(v0) + u0,
                                 background.stride, u1 - u0, v1 - v0, saturated);
    // At least half of the tile measured.
    if (sum_bb == 0 || 2 * count < static_cast<std::uint32_t>((u1 - u0) * (v1 - v0))) continue;
    const double n = count;
    const double gain = static_cast<double>(sum_lb) / sum_bb;
    if (gain < kLowestGain || gain > kHighestGain) continue;
    const double residual = static_cast<double>(sum_ll) - gain * sum_lb;
    const double texture = sum_bb - static_cast<double>(sum_b) * sum_b / n;
    if (gain * gain * texture < kTexture * n * noise2) continue;  // too flat to tell
    if (residual > kResidual * n * noise2) continue;              // not one gain: something else
    if (!unchangedUnder(frame, background, tile, static_cast<float>(gain), threshold, saturated)) {
      continue;
    }
    state_[tile] = kExplained;
    queue_.push_back({static_cast<std::uint32_t>(tile), static_cast<float>(gain), 0});
  }
  // Then their gains spread to changed neighbours that are unchanged under them, tile by tile, in
  // order of distance (a breadth-first walk), as far as kReach.
  for (std::size_t next = 0; next < queue_.size(); ++next) {
    const Seed seed = queue_[next];
    if (seed.steps >= kReach) continue;
    const std::size_t column = seed.tile % across_;
    const std::size_t row = seed.tile / across_;
    const std::size_t neighbours[4] = {
        column > 0 ? seed.tile - 1 : state_.size(),
        column + 1 < across_ ? seed.tile + 1 : state_.size(),
        row > 0 ? seed.tile - across_ : state_.size(),
        row + 1 < down_ ? seed.tile + across_ : state_.size(),
    };
    for (const std::size_t tile : neighbours) {
      if (tile >= state_.size() || state_[tile] != kChanged) continue;
      if (!unchangedUnder(frame, background, tile, seed.gain, threshold, saturated)) continue;
      state_[tile] = kExplained;
      queue_.push_back({static_cast<std::uint32_t>(tile), seed.gain, seed.steps + 1});
    }
  }
  for (const Seed& seed : queue_) clearTile(changed_tiles, seed.tile);
  return queue_.size();
}

}  // namespace occmap
