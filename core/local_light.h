#pragma once
// Light that changes in one part of a camera's view only: a lamp switched on in a corner, a patch
// of sun, the soft shadow at a person's feet (issue 13, docs/lighting.md). The light's gain
// (core/lighting_model.h) is one number for the whole view, so such a change is left in the
// changed-pixel tiles; this step takes out of them what light explains and nothing that stands on
// the floor.
//
// A change of light multiplies the background's grey levels by a gain and keeps its texture; an
// object hides the texture. So:
// - A changed 8 x 8 tile whose background has texture (a seam, grain, a pattern) is light when one
//   gain g maps the background onto the frame within the noise (least squares through the origin)
//   and every pixel passes the usual test against g x background. The texture must be strong
//   enough that anything hiding it would leave more than the noise: an object cannot pass.
// - Light that changes across a tile (a lamp's or a shadow's soft edge) fits no one gain. Such a
//   tile next to light already found is a seed too when a gain that changes linearly across it
//   fits within the noise, by the same rules, with the texture that a plane leaves: over a
//   background that is only a ramp, a flat object fits a sloped gain as well as light does.
// - A changed tile without texture tells light and object apart only by its level. It is light
//   when every pixel passes the usual test against g x background with the gain g of a textured
//   tile found as light and reached from it through changed tiles, at most kReach tiles away. The
//   gain is carried from that tile unchanged, never re-estimated on the way, so a chain of tiles
//   cannot drift into an object. The reach is short because a flat object touching a lit patch,
//   as bright as the patch, looks like more of the patch (a white box by a patch of sun, dark
//   trousers by a shadow): such an object may lose its outer tiles, never its middle.
// Either way a tile is cleared only if every pixel is unchanged under the threshold against the
// background in the local light: what a background taken in that light would find is still found.
// And a changed tile that matches the background as it was captured is cleared: the drift may have
// learnt a light that has gone again (a lamp switched off), and the empty scene as captured holds
// nothing that stands there.
// A flat floor with no texture anywhere under a lamp stays changed (it looks like a flat object),
// until the background is taken again.
// No I/O, no threads; after construction nothing is allocated.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "core/image.h"

namespace occmap {

class LocalLight {
 public:
  LocalLight(int width, int height);

  // `frame` and `background` in the same light (the frame corrected by the global gain),
  // `noise` the pixels' noise (standard deviation, grey levels) in that light, `threshold` the
  // difference's threshold, `saturated` the grey level from which a frame's pixel may be clipped
  // (it says only "at least this bright"), `changed_tiles` the frame's changed-pixel tiles
  // (core/fusion_kernel.h's layout). Clears the tiles that light explains; returns how many.
  // `captured`, if not empty, is the background as it was captured (before any drift): a changed
  // tile that matches it, pixel by pixel under the threshold, is explained too.
  std::size_t explain(ImageView frame, ImageView background, ImageView captured, double noise,
                      int threshold, int saturated, std::uint8_t* changed_tiles);
  // What the last explain() found of the changed tiles: how many it cleared and why, and of those
  // no seed, the first rule each failed.
  struct Tally {
    std::uint64_t changed = 0;
    std::uint64_t as_captured = 0;   // cleared: the background as captured
    std::uint64_t seeds = 0;         // cleared: textured, one gain
    std::uint64_t reached = 0;       // cleared: a seed's gain carried to them
    std::uint64_t clipped = 0;       // no seed: less than a quarter of the tile measured
    std::uint64_t out_of_range = 0;  // no seed: its gain beyond a fifth to five times
    std::uint64_t flat = 0;          // no seed: too little texture to tell
    std::uint64_t misfit = 0;        // no seed: no one gain fits
    std::uint64_t pixel = 0;         // no seed: one gain fits, a pixel past the threshold
    std::uint64_t sloped = 0;        // seeds whose gain changes across the tile
  };
  const Tally& tally() const { return tally_; }
  friend Tally& operator+=(Tally& sum, const Tally& more) {
    sum.changed += more.changed;
    sum.as_captured += more.as_captured;
    sum.seeds += more.seeds;
    sum.reached += more.reached;
    sum.clipped += more.clipped;
    sum.out_of_range += more.out_of_range;
    sum.flat += more.flat;
    sum.misfit += more.misfit;
    sum.pixel += more.pixel;
    sum.sloped += more.sloped;
    return sum;
  }
  // Whether the last explain() cleared the tile as light in part of the view (a seed, or reached
  // from one), not as the background as captured. Such a tile is not learnt by the drift
  // (LightingModel::follow): it is explained anew every frame from its own evidence.
  bool lit(std::size_t tile) const { return state_[tile] == kLit; }
  // Calls each(tile) for every tile the last explain() cleared.
  template <typename Each>
  void forEachExplainedTile(Each&& each) const {
    for (const Seed& seed : queue_) each(static_cast<std::size_t>(seed.tile));
  }

  // A tile is light when the squared misfit of one gain over its n pixels is under kResidual
  // times what noise alone leaves (n sigma^2: the bound lies some 11 standard deviations of that
  // chi-square sum above its mean, for a lamp's gradient across a tile), and its texture is such
  // that a flat object hiding it (which leaves about gain^2 x the texture) would leave twice that.
  // Measured on sim://room-lamps (docs/lighting.md), the residual is the test that binds: a lamp's
  // gradient across a tile adds to the noise. A residual bound of 1.7 (four standard deviations)
  // left a tenth of the seeds; 4 or 6 (with texture twice that) lost more seeds to the texture
  // rule than they gained.
  static constexpr double kResidual = 3.0;
  static constexpr double kTexture = 6.0;
  // How far, in tiles, a textured tile's gain reaches through tiles without texture.
  static constexpr int kReach = 3;

 private:
  // kMisfit: changed, textured, and one gain does not fit it. kLit: cleared as light; kCaptured:
  // cleared as the background as captured.
  enum State : std::uint8_t { kUnchanged, kChanged, kMisfit, kLit, kCaptured };
  struct Seed {
    std::uint32_t tile;
    float gain;
    int steps;  // from the textured tile whose gain this is
  };
  // A tile's pixels: [u0, u1) x [v0, v1), cut by the image's edge.
  struct TilePixels {
    int u0, v0, u1, v1;
  };
  TilePixels pixelsOf(std::size_t tile) const {
    const int u0 = static_cast<int>(tile % across_) * 8;
    const int v0 = static_cast<int>(tile / across_) * 8;
    return {u0, v0, std::min(width_, u0 + 8), std::min(height_, v0 + 8)};
  }
  // A tile's light: a gain at its middle (pixel (4, 4) of the tile), changing by per_u and per_v a
  // pixel across and down.
  struct Light {
    float gain = 1.0f;
    float per_u = 0.0f;
    float per_v = 0.0f;
  };
  // Whether every pixel of the tile passes |frame - gain x background| < threshold (a clipped one:
  // gain x background + threshold above where clipping starts), the gain the light's at the pixel.
  bool unchangedUnder(ImageView frame, ImageView background, std::size_t tile, const Light& light,
                      int threshold, int saturated) const;
  // The least-squares light that changes linearly across the tile, over its pixels below
  // `saturated`, if the tile is a seed of it: the fit's squared misfit under kResidual n sigma²,
  // the background's texture that a plane leaves (the misfit of its own least-squares plane: a
  // flat object over a floor that is only a ramp fits a sloped gain too) at least kTexture n sigma²
  // over gain², the gain at every corner within the bounds, and every pixel unchanged under it.
  std::optional<Light> slopedSeed(ImageView frame, ImageView background, std::size_t tile,
                                  double noise2, int threshold, int saturated) const;

  int width_;
  int height_;
  std::size_t across_;
  std::size_t down_;
  std::vector<std::uint8_t> state_;  // per tile, a State
  std::vector<Seed> queue_;          // tiles found as light, to spread their gain from
  Tally tally_;
};

}  // namespace occmap
