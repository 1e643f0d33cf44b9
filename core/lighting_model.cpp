#include "core/lighting_model.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "core/fusion_kernel.h"
#include "core/lighting_steps.h"

namespace occmap {
namespace {

// The gain is looked for between 1/4 and 4, in log-ratio bins of about 0.5 %.
constexpr int kBins = 512;
constexpr double kLogRange = 1.3862943611198906;  // ln 4
constexpr double kBinsPerLog = kBins / (2 * kLogRange);
// Background grey levels whose ratio says something: darker ones are mostly noise, brighter ones
// may be clipped. Live grey levels at or above kSaturated say only "at least this bright".
constexpr int kDarkest = 16;
constexpr int kBrightest = 235;
constexpr int kSaturated = 250;
// Fewer usable samples than this (lights out, a covered lens): nothing is explained.
constexpr std::size_t kFewestSamples = 64;
constexpr lighting_steps::Usable kUsable{kDarkest, kBrightest, kSaturated};
// The median of the log ratios is found from every kMedianStride-th usable sample (some 4 800 of a
// 640 x 480 frame's 19 200); the gain is then the least-squares fit over all that agree with it.
constexpr std::size_t kMedianStride = 4;

// The share of the samples that agree with the light: of the usable ones and of those the light
// clips as it says (which agree too: in a light that clips most of the view, what is left usable is
// mostly what stands in it).
double agreeingShare(std::size_t agreeing, std::size_t clipped, std::size_t usable) {
  return static_cast<double>(agreeing + clipped) /
         static_cast<double>(std::max<std::size_t>(1, usable + clipped));
}

// The log-ratio bin of every pair of grey levels, at [background << 8 | live]: ln(l + 0.5) -
// ln(b + 0.5) in bins of kBins over [-ln 4, ln 4], or kUnusable for a pair that says nothing of
// the gain (a background too dark or too bright, a live pixel black or clipped). One look-up per
// sample instead of two logarithms' difference in double precision, with the same bins.
constexpr std::uint16_t kUnusable = kBins;
const std::array<std::uint16_t, 65536>& binOfPair() {
  static const std::array<std::uint16_t, 65536> table = [] {
    std::array<double, 256> ln{};
    for (int v = 0; v < 256; ++v) {
      // In float as before the table (the bins are those of the float logarithms).
      ln[static_cast<std::size_t>(v)] = static_cast<double>(std::log(static_cast<float>(v) + 0.5f));
    }
    std::array<std::uint16_t, 65536> t{};
    for (int b = 0; b < 256; ++b) {
      for (int l = 0; l < 256; ++l) {
        std::uint16_t bin = kUnusable;
        if (lighting_steps::usableSample(static_cast<std::uint16_t>(b << 8 | l), kUsable)) {
          const double ratio = ln[static_cast<std::size_t>(l)] - ln[static_cast<std::size_t>(b)];
          bin = static_cast<std::uint16_t>(
              std::clamp(static_cast<int>((ratio + kLogRange) * kBinsPerLog), 0, kBins - 1));
        }
        t[static_cast<std::size_t>(b << 8 | l)] = bin;
      }
    }
    return t;
  }();
  return table;
}

}  // namespace

LightingModel::LightingModel(ImageView background, const LightingSettings& settings)
    : settings_(settings) {
  if (settings_.drift_frames < 1) throw std::invalid_argument("drift_frames must be at least 1");
  reset(background);
}

void LightingModel::reset(ImageView background) {
  if (background.empty() || background.width <= 0 || background.height <= 0) {
    throw std::invalid_argument("LightingModel: an empty background");
  }
  width_ = background.width;
  height_ = background.height;
  const std::size_t pixels = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
  reference_q8_.resize(pixels);
  reference_ = Image(width_, height_);
  captured_ = Image(width_, height_);
  corrected_ = Image(width_, height_);
  capped_ = Image(width_, height_);
  for (int v = 0; v < height_; ++v) {
    std::memcpy(reference_.row(v), background.row(v), static_cast<std::size_t>(width_));
    std::memcpy(captured_.row(v), background.row(v), static_cast<std::size_t>(width_));
    for (int u = 0; u < width_; ++u) {
      reference_q8_[static_cast<std::size_t>(v) * static_cast<std::size_t>(width_) +
                    static_cast<std::size_t>(u)] =
          static_cast<std::uint16_t>(background.at(u, v) << 8);
    }
  }
  histogram_.assign(kBins, 0);
  quiet_row_.assign(tilesAcross(width_) * 8, 0);
  const std::size_t samples =
      samplesPerRow() * static_cast<std::size_t>((height_ + kSampleStep - 1) / kSampleStep);
  samples_.assign(samples, 0);
  static_assert(kSampleStep == 4, "lighting_steps::samplePairs takes every fourth pixel");
  usable_ = 0;
  agreeing_ = 0;
  clipped_ = 0;
  if (settings_.local) local_.emplace(width_, height_);
  gain_ = 1.0;
  agreement_ = 1.0;
  noise_ = 1.0;
  locally_explained_ = 0;
  explained_ = true;
  capped_in_use_ = false;
  capped_cap_ = 255;
  frames_ = 0;
  updateInverse();
}

void LightingModel::estimateGain(ImageView live) {
  const std::array<std::uint16_t, 65536>& bin_of = binOfPair();
  const std::size_t per_row = samplesPerRow();
  std::uint16_t* samples = samples_.data();
  for (int v = 0, row = 0; v < height_; v += kSampleStep, ++row) {
    // A live frame comes from the camera, not from the cache: the next sampled row is asked for
    // while this one is read (each sample would otherwise wait for memory).
    if (const int next = v + 2 * kSampleStep; next < height_) {
      const std::uint8_t* ahead = live.row(next);
      for (int u = 0; u < width_; u += 64) __builtin_prefetch(ahead + u);
    }
    lighting_steps::samplePairs(reference_.row(v), live.row(v), width_,
                                samples + static_cast<std::size_t>(row) * per_row);
  }
  // The median's histogram takes every kMedianStride-th sample that is usable.
  std::fill(histogram_.begin(), histogram_.end(), 0u);
  std::size_t counted = 0;
  for (std::size_t s = 0; s < samples_.size(); s += kMedianStride) {
    const std::uint16_t bin = bin_of[samples[s]];
    if (bin == kUnusable) continue;
    ++histogram_[bin];
    ++counted;
  }
  usable_ = 0;
  agreeing_ = 0;
  clipped_ = 0;
  if (counted == 0) {
    agreement_ = 0.0;
    explained_ = false;
    return;
  }
  // The median ratio: right while less than half of the usable samples see something else.
  std::size_t below = 0;
  int median_bin = 0;
  while (median_bin < kBins - 1 &&
         2 * (below + histogram_[static_cast<std::size_t>(median_bin)]) < counted) {
    below += histogram_[static_cast<std::size_t>(median_bin)];
    ++median_bin;
  }
  const double median = std::exp((median_bin + 0.5) / kBinsPerLog - kLogRange);
  // Then the least-squares gain over the samples that agree with it (bright pixels weigh more:
  // their ratio is the least noisy).
  // The band widens with a brighter light: the background's rounding and a camera gain's noise
  // grow with it.
  const auto band = [&](double gain) {
    return static_cast<float>(settings_.agreement_grey_levels * std::max(1.0, gain));
  };
  const auto judge = [&](double gain) {
    return lighting_steps::agreement(samples_.data(), samples_.size(), static_cast<float>(gain),
                                     band(gain), kUsable);
  };
  const auto share = [](const lighting_steps::Agreement& sums) {
    return agreeingShare(sums.agreeing, sums.clipped, sums.usable);
  };
  double judged_by = median;
  lighting_steps::Agreement sums = judge(median);
  // And then the median of the usable samples may be theirs, not the light's (measured: at twice
  // the light, in sim://room-gains, the median of a camera beside people fell from 1.9 to 1.08
  // for two frames). When the median's gain explains too little, the last frame's gain is tried
  // too, and the one that explains more is kept.
  if (share(sums) < settings_.min_agreement && frames_ > 0 &&
      std::abs(std::log(gain_ / median)) * kBinsPerLog > 1.0) {
    const lighting_steps::Agreement last = judge(gain_);
    if (share(last) > share(sums)) {
      sums = last;
      judged_by = gain_;
    }
  }
  agreement_gain_ = static_cast<float>(judged_by);
  agreement_band_ = band(judged_by);
  usable_ = sums.usable;
  if (usable_ < kFewestSamples) {
    agreement_ = 0.0;
    explained_ = false;
    return;
  }
  agreeing_ = sums.agreeing;
  clipped_ = sums.clipped;
  agreement_ = share(sums);
  explained_ = agreement_ >= settings_.min_agreement && sums.sum_bb > 0.0;
  // The gain of what agrees, even when too little agrees for the frame to count yet: a light in
  // part of the view (explainLocally) may explain the rest.
  if (agreeing_ >= kFewestSamples && sums.sum_bb > 0.0) {
    gain_ = std::clamp(sums.sum_lb / sums.sum_bb, 0.25, 4.0);
    // The squared residuals about the gain the samples were judged by, from the exact sums; in
    // the background's light, as the frame is compared.
    const double squared_residuals = std::max(
        0.0, sums.sum_ll - 2.0 * judged_by * sums.sum_lb + judged_by * judged_by * sums.sum_bb);
    noise_ = std::sqrt(squared_residuals / static_cast<double>(agreeing_)) / gain_;
  }
}

void LightingModel::updateInverse() {
  // 1 / gain in 16.16 (gain >= 1/4, so at most 2^18: l x inverse stays within 31 bits).
  inverse_gain_q16_ = static_cast<std::int32_t>(std::lround(65536.0 / gain_));
}

ImageView LightingModel::correct(ImageView live) {
  if (live.width != width_ || live.height != height_) {
    throw std::invalid_argument("LightingModel: the frame's size differs from the background's");
  }
  estimateGain(live);
  updateInverse();
  ++frames_;
  local_ran_ = false;
  // live / gain, rounded, at most 255: in 16.16 fixed point (core/lighting_steps.h).
  const std::int32_t inverse = inverse_gain_q16_;
  // In light within 0.2 % of the background's, dividing changes no grey level (255 / gain rounds
  // to 255): the frame is its own corrected self, and nothing is clipped.
  if (std::abs(inverse - 65536) * 255 < 32768) {
    capped_in_use_ = false;
    return live;
  }
  for (int v = 0; v < height_; ++v) {
    lighting_steps::inBackgroundsLight(live.row(v), width_, inverse, corrected_.row(v));
  }
  // A pixel at 255 reads `cap` in the background's light: a background above that would have been
  // clipped too, so it is compared as that.
  const auto cap = static_cast<std::uint8_t>(std::min(255, (255 * inverse + 32768) >> 16));
  capped_in_use_ = cap < 255;
  // The capped background is made again only when the cap moves (follow() keeps the rows it
  // drifts capped): in a steady light, not at every frame.
  if (capped_in_use_ && cap != capped_cap_) {
    const std::size_t pixels = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
    lighting_steps::atMost(reference_.data(), pixels, cap, capped_.data());
    capped_cap_ = cap;
  }
  return corrected_.view();
}

ImageView LightingModel::background() const {
  return capped_in_use_ ? capped_.view() : reference_.view();
}

std::size_t LightingModel::explainLocally(ImageView corrected, int threshold,
                                          std::uint8_t* changed_tiles) {
  locally_explained_ = 0;
  if (!local_ || frames_ == 0 || agreeing_ < kFewestSamples) return 0;
  // Where the sensor clips, in the background's light.
  const int saturated = (kSaturated * inverse_gain_q16_ + 32768) >> 16;
  locally_explained_ = local_->explain(corrected, background(), captured_.view(), noise_, threshold,
                                       saturated, changed_tiles);
  local_ran_ = true;
  // The samples that disagreed with the gain but lie where a local light explains the change count
  // as agreeing: a lamp over a third of the view is light, not a bumped camera. Each tile holds the
  // four samples at its pixels (0, 0), (4, 0), (0, 4) and (4, 4).
  const std::size_t per_row = samplesPerRow();
  const std::size_t across = tilesAcross(width_);
  std::size_t explained_here = 0;
  local_->forEachExplainedTile([&](std::size_t tile) {
    const int u0 = static_cast<int>(tile % across) * 8;
    const int v0 = static_cast<int>(tile / across) * 8;
    for (int v = v0; v < std::min(height_, v0 + 8); v += kSampleStep) {
      for (int u = u0; u < std::min(width_, u0 + 8); u += kSampleStep) {
        const std::uint16_t sample = samples_[static_cast<std::size_t>(v / kSampleStep) * per_row +
                                              static_cast<std::size_t>(u / kSampleStep)];
        explained_here += lighting_steps::usableSample(sample, kUsable) &&
                                  !lighting_steps::agrees(sample, agreement_gain_, agreement_band_)
                              ? 1
                              : 0;
      }
    }
  });
  agreement_ = agreeingShare(agreeing_ + explained_here, clipped_, usable_);
  explained_ = agreement_ >= settings_.min_agreement;
  return locally_explained_;
}

void LightingModel::follow(ImageView live, const std::uint8_t* changed_tiles) {
  if (!explained_ || frames_ == 0) return;
  // Each pixel is visited every kBands frames, so each visit covers kBands frames of drift. In
  // 16.16 fixed point, at most 1/2: a difference (16 bits and a sign) times it stays within 32
  // bits, and a drift faster than half of a lasting difference every visit (drift_frames < 2
  // kBands) is no drift anyway.
  const std::int32_t alpha_q16 = static_cast<std::int32_t>(std::clamp<long>(
      std::lround(65536.0 * kBands / std::max(settings_.drift_frames, kBands)), 1, 32768));
  // live / gain x 256, in 16.16: the live pixel in the background's light, in its fine steps.
  const std::int32_t inverse = inverse_gain_q16_;
  const std::size_t across = tilesAcross(width_);
  const std::size_t down = tilesDown(height_);
  const std::size_t band = static_cast<std::size_t>((frames_ - 1) % kBands);
  const std::size_t first = band * down / kBands;
  const std::size_t last = (band + 1) * down / kBands;
  std::uint8_t* quiet = quiet_row_.data();
  const LocalLight* lit = local_ran_ ? &*local_ : nullptr;  // its tiles cleared as light
  for (std::size_t tile_row = first; tile_row < last; ++tile_row) {
    // 1 for every pixel of a wholly unchanged tile: only there is anything learnt. Not where the
    // local light cleared the tile as light in part of the view: that light is explained anew
    // every frame from the background's texture, never learnt. Learnt, the tiles it cleared
    // would stop being changed and so stop being seeds, while their flat neighbours, which only
    // a seed's gain reaches, stayed changed for good (measured: a lamp's pool left as a
    // patchwork of learnt and changed tiles, docs/lighting.md); and an object as bright as the
    // light next to it, whose outer tiles the light's reach clears, would be learnt.
    bool any = false;
    for (std::size_t tile = 0; tile < across; ++tile) {
      const std::size_t index = tile_row * across + tile;
      std::uint64_t word;
      std::memcpy(&word, changed_tiles + index * 8, sizeof word);
      const bool learn = word == 0 && (lit == nullptr || !lit->lit(index));
      std::memset(quiet + tile * 8, learn ? 1 : 0, 8);
      any = any || learn;
    }
    if (!any) continue;
    const int v0 = static_cast<int>(tile_row * 8);
    const int v1 = std::min(height_, v0 + 8);
    for (int v = v0; v < v1; ++v) {
      // A clipped pixel (at kSaturated or above) says only "at least this bright": nothing is
      // learnt from it.
      lighting_steps::driftRow(live.row(v), quiet, width_, inverse, alpha_q16, kSaturated,
                               reference_q8_.data() + static_cast<std::ptrdiff_t>(v) * width_,
                               reference_.row(v));
      if (capped_cap_ < 255) {
        lighting_steps::atMost(reference_.row(v), static_cast<std::size_t>(width_), capped_cap_,
                               capped_.row(v));
      }
    }
  }
}

}  // namespace occmap
