#pragma once
// The light's model's per-pixel passes (core/lighting_model.h), each twice: SIMD through Google
// Highway, dispatched at run time to the best target this CPU has, and plain scalar C++, the
// yardstick the tests hold every SIMD target to. All are integer arithmetic, sums of integers
// (exact in any order) and one comparison done in float with the scalar's very operations, so
// every target gives the same results. Internal to core/lighting_model.cpp, core/local_light.cpp
// and core/view_motion.cpp, and exposed for their tests.

#include <cmath>
#include <cstddef>
#include <cstdint>

namespace occmap::lighting_steps {

// One row of a frame put in the background's light: out = min(255, round(live / gain)), with
// 1 / gain as `inverse_q16` in 16.16 fixed point (at most 2^18).
void inBackgroundsLight(const std::uint8_t* live, int width, std::int32_t inverse_q16,
                        std::uint8_t* out);
void inBackgroundsLightScalar(const std::uint8_t* live, int width, std::int32_t inverse_q16,
                              std::uint8_t* out);

// count bytes: out = min(in, cap).
void atMost(const std::uint8_t* in, std::size_t count, std::uint8_t cap, std::uint8_t* out);

// One row of the drift (LightingModel::follow). `fine` is the background x 256. Where quiet[u] is
// not 0 and live[u] < saturated, fine[u] moves toward live[u] / gain x 256 (`inverse_q16` as
// above) by `alpha_q16` (16.16, at most 1/2) of the difference, rounded toward minus infinity but
// at least one fine step up when the target is above; elsewhere it stays. grey[u] becomes fine[u]
// rounded to grey levels, at most 255, for every pixel.
void driftRow(const std::uint8_t* live, const std::uint8_t* quiet, int width,
              std::int32_t inverse_q16, std::int32_t alpha_q16, int saturated, std::uint16_t* fine,
              std::uint8_t* grey);
void driftRowScalar(const std::uint8_t* live, const std::uint8_t* quiet, int width,
                    std::int32_t inverse_q16, std::int32_t alpha_q16, int saturated,
                    std::uint16_t* fine, std::uint8_t* grey);

// The gain's samples along one row (LightingModel::estimateGain): every fourth pixel from u = 0,
// (width + 3) / 4 of them, each as background << 8 | live.
void samplePairs(const std::uint8_t* background, const std::uint8_t* live, int width,
                 std::uint16_t* pairs);
void samplePairsScalar(const std::uint8_t* background, const std::uint8_t* live, int width,
                       std::uint16_t* pairs);

// The gain's agreement (LightingModel::estimateGain). Of `count` samples, each a background and a
// live grey level as background << 8 | live, those that say something of the gain are usable: a
// background within [darkest, brightest] (darker ones are mostly noise, brighter ones may clip)
// and a live grey level of at least 2 and below `saturated`. Of those, the ones with
// |live - gain x background| < band agree (agrees() below, the very operations of every target):
// their count and their sums of live x background, background² and live² (integers, exact in a
// double). And the samples the light clips as it says (clippedAsTheLightSays()), counted apart:
// they say nothing of the gain, but they agree with it.
struct Usable {
  int darkest = 0;
  int brightest = 255;
  int saturated = 256;
};
struct Agreement {
  double sum_lb = 0.0;
  double sum_bb = 0.0;
  double sum_ll = 0.0;
  std::size_t usable = 0;
  std::size_t agreeing = 0;
  std::size_t clipped = 0;
};
Agreement agreement(const std::uint16_t* samples, std::size_t count, float gain, float band,
                    Usable usable);
Agreement agreementScalar(const std::uint16_t* samples, std::size_t count, float gain, float band,
                          Usable usable);

inline bool usableSample(std::uint16_t sample, Usable usable) {
  const int b = sample >> 8;
  const int l = sample & 0xFF;
  return b >= usable.darkest && b <= usable.brightest && l >= 2 && l < usable.saturated;
}
// In float, without a fused multiply-add (core/CMakeLists.txt): as every SIMD target does it.
inline bool agrees(std::uint16_t sample, float gain, float band) {
  const auto b = static_cast<float>(sample >> 8);
  const auto l = static_cast<float>(sample & 0xFF);
  return std::abs(l - gain * b) < band;
}
// A live grey level at `saturated` or above over a background of at least `darkest` that the gain
// says is clipped too (gain x background within the band of `saturated`, or above): in a bright
// light most of a view may clip, and what is left usable is then mostly what stands in it.
inline bool clippedAsTheLightSays(std::uint16_t sample, float gain, float band, Usable usable) {
  const int b = sample >> 8;
  const int l = sample & 0xFF;
  return b >= usable.darkest && l >= usable.saturated &&
         gain * static_cast<float>(b) + band >= static_cast<float>(usable.saturated);
}

// One tile's sums for the local light's fit (core/local_light.h): over the `width` x `height`
// pixels (at most 8 x 8) from `frame` and `background` (rows `frame_stride` and
// `background_stride` bytes apart), those whose frame pixel is below `saturated`: their count and
// their sums of b, b², l x b and l².
struct TileSums {
  std::uint32_t count = 0;
  std::uint32_t sum_b = 0;
  std::uint32_t sum_bb = 0;
  std::uint32_t sum_lb = 0;
  std::uint32_t sum_ll = 0;
};
TileSums tileSums(const std::uint8_t* frame, std::ptrdiff_t frame_stride,
                  const std::uint8_t* background, std::ptrdiff_t background_stride, int width,
                  int height, int saturated);
TileSums tileSumsScalar(const std::uint8_t* frame, std::ptrdiff_t frame_stride,
                        const std::uint8_t* background, std::ptrdiff_t background_stride, int width,
                        int height, int saturated);

// The sums a correlation of two rows of `count` pixels (at most 65536) needs: of b, l, b², l² and
// b x l (core/view_motion.h's zero-mean normalised cross-correlation).
struct CorrelationSums {
  std::uint64_t sum_b = 0;
  std::uint64_t sum_l = 0;
  std::uint64_t sum_bb = 0;
  std::uint64_t sum_ll = 0;
  std::uint64_t sum_bl = 0;
};
CorrelationSums correlationSums(const std::uint8_t* b, const std::uint8_t* l, std::size_t count);
CorrelationSums correlationSumsScalar(const std::uint8_t* b, const std::uint8_t* l,
                                      std::size_t count);

}  // namespace occmap::lighting_steps
