#include "core/lighting_model.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "core/fusion_kernel.h"

namespace occmap {
namespace {

// The gain is looked for between 1/4 and 4, in log-ratio bins of about 0.5 %.
constexpr int kBins = 512;
constexpr double kLogRange = 1.3862943611198906;  // ln 4
// Background grey levels whose ratio says something: darker ones are mostly noise, brighter ones
// may be clipped. Live grey levels at or above kSaturated say only "at least this bright".
constexpr int kDarkest = 16;
constexpr int kBrightest = 235;
constexpr int kSaturated = 250;
// Fewer usable samples than this (lights out, a covered lens): nothing is explained.
constexpr std::size_t kFewestSamples = 64;

// ln(v + 0.5) for every grey level: the log-ratio of two pixels is a difference of two of these.
const std::array<float, 256>& logOfGrey() {
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (int v = 0; v < 256; ++v)
      t[static_cast<std::size_t>(v)] = std::log(static_cast<float>(v) + 0.5f);
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
  corrected_ = Image(width_, height_);
  capped_ = Image(width_, height_);
  for (int v = 0; v < height_; ++v) {
    std::memcpy(reference_.row(v), background.row(v), static_cast<std::size_t>(width_));
    for (int u = 0; u < width_; ++u) {
      reference_q8_[static_cast<std::size_t>(v) * static_cast<std::size_t>(width_) +
                    static_cast<std::size_t>(u)] =
          static_cast<std::uint16_t>(background.at(u, v) << 8);
    }
  }
  histogram_.assign(kBins, 0);
  const std::size_t samples = static_cast<std::size_t>((width_ + kSampleStep - 1) / kSampleStep) *
                              static_cast<std::size_t>((height_ + kSampleStep - 1) / kSampleStep);
  sample_at_.assign(samples, 0);
  gain_ = 1.0;
  agreement_ = 1.0;
  explained_ = true;
  capped_in_use_ = false;
  frames_ = 0;
  buildTables();
}

void LightingModel::estimateGain(ImageView live) {
  const auto& ln = logOfGrey();
  std::fill(histogram_.begin(), histogram_.end(), 0u);
  std::size_t usable = 0;
  constexpr double kBinsPerLog = kBins / (2 * kLogRange);
  for (int v = 0; v < height_; v += kSampleStep) {
    const std::uint8_t* background = reference_.row(v);
    const std::uint8_t* frame = live.row(v);
    for (int u = 0; u < width_; u += kSampleStep) {
      const int b = background[u];
      const int l = frame[u];
      if (b < kDarkest || b > kBrightest || l >= kSaturated || l < 2) continue;
      const double ratio = static_cast<double>(ln[static_cast<std::size_t>(l)]) -
                           static_cast<double>(ln[static_cast<std::size_t>(b)]);
      const int bin = std::clamp(static_cast<int>((ratio + kLogRange) * kBinsPerLog), 0, kBins - 1);
      ++histogram_[static_cast<std::size_t>(bin)];
      sample_at_[usable++] = static_cast<std::uint32_t>(v * width_ + u);
    }
  }
  if (usable < kFewestSamples) {
    agreement_ = 0.0;
    explained_ = false;
    return;
  }
  // The median ratio: right while less than half of the usable samples see something else.
  std::size_t below = 0;
  int median_bin = 0;
  while (median_bin < kBins - 1 &&
         2 * (below + histogram_[static_cast<std::size_t>(median_bin)]) < usable) {
    below += histogram_[static_cast<std::size_t>(median_bin)];
    ++median_bin;
  }
  const double median = std::exp((median_bin + 0.5) / kBinsPerLog - kLogRange);
  // Then the least-squares gain over the samples that agree with it (bright pixels weigh more:
  // their ratio is the least noisy).
  double sum_lb = 0.0;
  double sum_bb = 0.0;
  std::size_t agreeing = 0;
  // The band widens with a brighter light: the background's rounding and a camera gain's noise
  // grow with it.
  const double band = settings_.agreement_grey_levels * std::max(1.0, median);
  for (std::size_t s = 0; s < usable; ++s) {
    const std::uint32_t at = sample_at_[s];
    const int v = static_cast<int>(at / static_cast<std::uint32_t>(width_));
    const int u = static_cast<int>(at % static_cast<std::uint32_t>(width_));
    const double b = reference_.data()[at];
    const double l = live.at(u, v);
    if (std::abs(l - median * b) < band) {
      ++agreeing;
      sum_lb += l * b;
      sum_bb += b * b;
    }
  }
  agreement_ = static_cast<double>(agreeing) / static_cast<double>(usable);
  explained_ = agreement_ >= settings_.min_agreement && sum_bb > 0.0;
  if (explained_) gain_ = std::clamp(sum_lb / sum_bb, 0.25, 4.0);
}

void LightingModel::buildTables() {
  for (int l = 0; l < 256; ++l) {
    const double in_reference = l / gain_;
    to_reference_[static_cast<std::size_t>(l)] =
        static_cast<std::uint8_t>(std::min(255.0, std::round(in_reference)));
    to_reference_q8_[static_cast<std::size_t>(l)] =
        static_cast<std::uint16_t>(std::min(65535.0, std::round(in_reference * 256.0)));
  }
}

ImageView LightingModel::correct(ImageView live) {
  if (live.width != width_ || live.height != height_) {
    throw std::invalid_argument("LightingModel: the frame's size differs from the background's");
  }
  estimateGain(live);
  buildTables();
  for (int v = 0; v < height_; ++v) {
    const std::uint8_t* in = live.row(v);
    std::uint8_t* out = corrected_.row(v);
    for (int u = 0; u < width_; ++u) out[u] = to_reference_[in[u]];
  }
  // A pixel at 255 reads to_reference_[255] in the background's light: a background above that
  // would have been clipped too, so it is compared as that.
  const std::uint8_t cap = to_reference_[255];
  capped_in_use_ = cap < 255;
  if (capped_in_use_) {
    const std::size_t pixels = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
    const std::uint8_t* in = reference_.data();
    std::uint8_t* out = capped_.data();
    for (std::size_t i = 0; i < pixels; ++i) out[i] = std::min(in[i], cap);
  }
  ++frames_;
  return corrected_.view();
}

ImageView LightingModel::background() const {
  return capped_in_use_ ? capped_.view() : reference_.view();
}

void LightingModel::follow(ImageView live, const std::uint8_t* changed_tiles) {
  if (!explained_ || frames_ == 0) return;
  // Each pixel is visited every kBands frames, so each visit covers kBands frames of drift.
  const std::int64_t alpha_q16 = std::max<std::int64_t>(
      1,
      std::llround(65536.0 * std::min(1.0, static_cast<double>(kBands) / settings_.drift_frames)));
  const std::size_t across = tilesAcross(width_);
  const std::size_t down = tilesDown(height_);
  const std::size_t band = static_cast<std::size_t>((frames_ - 1) % kBands);
  const std::size_t first = band * down / kBands;
  const std::size_t last = (band + 1) * down / kBands;
  for (std::size_t tile_row = first; tile_row < last; ++tile_row) {
    const int v0 = static_cast<int>(tile_row * 8);
    const int v1 = std::min(height_, v0 + 8);
    for (std::size_t tile = 0; tile < across; ++tile) {
      std::uint64_t word;
      std::memcpy(&word, changed_tiles + (tile_row * across + tile) * 8, sizeof word);
      if (word != 0) continue;  // something changed in this tile: leave all of it
      const int u0 = static_cast<int>(tile * 8);
      const int u1 = std::min(width_, u0 + 8);
      for (int v = v0; v < v1; ++v) {
        const std::uint8_t* frame = live.row(v);
        std::uint16_t* fine = reference_q8_.data() + static_cast<std::ptrdiff_t>(v) * width_;
        std::uint8_t* grey = reference_.row(v);
        for (int u = u0; u < u1; ++u) {
          const int l = frame[u];
          if (l >= kSaturated) continue;  // only "at least this bright": nothing to learn
          const std::int64_t difference =
              std::int64_t{to_reference_q8_[static_cast<std::size_t>(l)]} - fine[u];
          if (difference == 0) continue;
          std::int64_t step = difference * alpha_q16 / 65536;
          if (step == 0) step = difference > 0 ? 1 : -1;
          const auto moved = static_cast<std::uint16_t>(fine[u] + step);
          fine[u] = moved;
          grey[u] = static_cast<std::uint8_t>(std::min(255, (moved + 128) >> 8));
        }
      }
    }
  }
}

}  // namespace occmap
