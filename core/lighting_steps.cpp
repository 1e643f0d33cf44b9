// The light's model's per-pixel passes, compiled once per SIMD target by Highway's foreach_target
// (this file includes itself once per target) and dispatched at run time; the scalar versions at
// the end are the yardstick, and each SIMD version's tail.
#include "core/lighting_steps.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "core/lighting_steps.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
// foreach_target.h must come first.
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace occmap::lighting_steps::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// 32-bit lanes: the products (a grey level times 1 / gain in 16.16, a fine difference times the
// drift's rate) need them. Bytes and fine values are widened on load and narrowed on store.
using WideTag = hn::ScalableTag<std::int32_t>;

void inBackgroundsLightVector(const std::uint8_t* HWY_RESTRICT live, int width,
                              std::int32_t inverse_q16, std::uint8_t* HWY_RESTRICT out) {
  // In 16-bit lanes, twice as many a vector as 32-bit ones and no widening past 16 bits: with
  // 1 / gain = whole + part / 2^16 (whole at most 4), (l x inverse + 2^15) >> 16 is l x whole plus
  // (l x part + 2^15) >> 16, and the latter is (floor(2 l x part / 2^16) + 1) >> 1 (exactly: both
  // round l x part / 2^16 half up), a high half of a 16-bit product and a rounded halving.
  const hn::ScalableTag<std::uint16_t> d;
  const hn::Rebind<std::uint8_t, decltype(d)> bytes;
  const hn::RebindToSigned<decltype(d)> signed_words;
  const std::size_t n = hn::Lanes(d);
  const std::size_t pixels = static_cast<std::size_t>(width);
  const auto whole = hn::Set(d, static_cast<std::uint16_t>(inverse_q16 >> 16));
  const auto part = hn::Set(d, static_cast<std::uint16_t>(inverse_q16 & 0xffff));
  const auto zero = hn::Zero(d);
  const auto brightest = hn::Set(d, 255);
  std::size_t u = 0;
  for (; u + n <= pixels; u += n) {
    const auto l = hn::PromoteTo(d, hn::LoadU(bytes, live + u));
    const auto fraction = hn::AverageRound(hn::MulHigh(hn::Add(l, l), part), zero);
    const auto scaled = hn::Min(brightest, hn::Add(hn::Mul(l, whole), fraction));
    // At most 255, so as signed 16-bit lanes too (Highway narrows those to bytes).
    hn::StoreU(hn::DemoteTo(bytes, hn::BitCast(signed_words, scaled)), bytes, out + u);
  }
  inBackgroundsLightScalar(live + u, static_cast<int>(pixels - u), inverse_q16, out + u);
}

void atMostVector(const std::uint8_t* HWY_RESTRICT in, std::size_t count, std::uint8_t cap,
                  std::uint8_t* HWY_RESTRICT out) {
  const hn::ScalableTag<std::uint8_t> d;
  const std::size_t n = hn::Lanes(d);
  const auto most = hn::Set(d, cap);
  std::size_t i = 0;
  for (; i + n <= count; i += n) hn::StoreU(hn::Min(hn::LoadU(d, in + i), most), d, out + i);
  for (; i < count; ++i) out[i] = std::min(in[i], cap);
}

void driftRowVector(const std::uint8_t* HWY_RESTRICT live, const std::uint8_t* HWY_RESTRICT quiet,
                    int width, std::int32_t inverse_q16, std::int32_t alpha_q16, int saturated,
                    std::uint16_t* HWY_RESTRICT fine, std::uint8_t* HWY_RESTRICT grey) {
  // In 16-bit lanes, exactly as the scalar's 32-bit arithmetic:
  // - The target l x inverse / 256, rounded, at most 65535, with 1 / gain = whole + part / 2^16:
  //   l x whole x 256 (all ones once l x whole passes 255) plus (l x part + 128) >> 8, which is the
  //   high half of (l << 8) x part plus bit 7 of the low half of l x part.
  // - The step alpha x (target - now) / 2^16 toward minus infinity, from the difference's size d:
  //   above, the high half of d x alpha (at least 1); below, minus that rounded up.
  const hn::ScalableTag<std::uint16_t> d;
  const hn::Rebind<std::uint8_t, decltype(d)> bytes;
  const hn::RebindToSigned<decltype(d)> signed_words;
  const std::size_t n = hn::Lanes(d);
  const std::size_t pixels = static_cast<std::size_t>(width);
  const auto whole = hn::Set(d, static_cast<std::uint16_t>(inverse_q16 >> 16));
  const auto part = hn::Set(d, static_cast<std::uint16_t>(inverse_q16 & 0xffff));
  const auto alpha = hn::Set(d, static_cast<std::uint16_t>(alpha_q16));
  const auto clipped = hn::Set(d, static_cast<std::uint16_t>(std::min(saturated, 65535)));
  const auto finest = hn::Set(d, 65535);
  const auto half_step = hn::Set(d, 128);
  const auto brightest = hn::Set(d, 255);
  const auto zero = hn::Zero(d);
  const auto one = hn::Set(d, 1);
  std::size_t u = 0;
  for (; u + n <= pixels; u += n) {
    const auto l = hn::PromoteTo(d, hn::LoadU(bytes, live + u));
    const auto whole_steps = hn::Mul(l, whole);  // at most 255 x 4
    const auto fraction = hn::Add(hn::MulHigh(hn::ShiftLeft<8>(l), part),
                                  hn::And(hn::ShiftRight<7>(hn::Mul(l, part)), one));
    const auto target = hn::SaturatedAdd(
        hn::IfThenElse(hn::Gt(whole_steps, brightest), finest, hn::ShiftLeft<8>(whole_steps)),
        fraction);
    const auto now = hn::LoadU(d, fine + u);
    const auto above = hn::Gt(target, now);
    const auto size = hn::Sub(hn::Max(target, now), hn::Min(target, now));
    const auto high = hn::MulHigh(size, alpha);
    const auto up = hn::Add(now, hn::Max(high, one));
    const auto down =
        hn::Sub(now, hn::Add(high, hn::IfThenElseZero(hn::Ne(hn::Mul(size, alpha), zero), one)));
    const auto is_quiet = hn::Ne(hn::PromoteTo(d, hn::LoadU(bytes, quiet + u)), zero);
    const auto learn = hn::And(is_quiet, hn::Lt(l, clipped));
    const auto moved = hn::IfThenElse(learn, hn::IfThenElse(above, up, down), now);
    hn::StoreU(moved, d, fine + u);
    const auto rounded = hn::Min(brightest, hn::ShiftRight<8>(hn::SaturatedAdd(moved, half_step)));
    hn::StoreU(hn::DemoteTo(bytes, hn::BitCast(signed_words, rounded)), bytes, grey + u);
  }
  driftRowScalar(live + u, quiet + u, static_cast<int>(pixels - u), inverse_q16, alpha_q16,
                 saturated, fine + u, grey + u);
}

void samplePairsVector(const std::uint8_t* HWY_RESTRICT background,
                       const std::uint8_t* HWY_RESTRICT live, int width,
                       std::uint16_t* HWY_RESTRICT pairs) {
  const hn::ScalableTag<std::uint16_t> d;
  const hn::Rebind<std::uint8_t, decltype(d)> bytes;
  const std::size_t n = hn::Lanes(d);
  const std::size_t pixels = static_cast<std::size_t>(width);
  std::size_t i = 0;  // the sample at pixel 4 i
  for (; 4 * (i + n) <= pixels; i += n) {
    // Every fourth byte is the first of each group of four; the other three are not used.
    hn::Vec<decltype(bytes)> b, l, other1, other2, other3;
    hn::LoadInterleaved4(bytes, background + 4 * i, b, other1, other2, other3);
    hn::LoadInterleaved4(bytes, live + 4 * i, l, other1, other2, other3);
    hn::StoreU(hn::Or(hn::ShiftLeft<8>(hn::PromoteTo(d, b)), hn::PromoteTo(d, l)), d, pairs + i);
  }
  samplePairsScalar(background + 4 * i, live + 4 * i, static_cast<int>(pixels - 4 * i), pairs + i);
}

Agreement agreementVector(const std::uint16_t* HWY_RESTRICT samples, std::size_t count, float gain,
                          float band, Usable usable) {
  const hn::ScalableTag<std::int32_t> d;
  const hn::Rebind<float, decltype(d)> df;
  const hn::Rebind<std::uint16_t, decltype(d)> d16;
  const hn::RebindToUnsigned<decltype(d)> du;
  const std::size_t n = hn::Lanes(d);
  const auto g = hn::Set(df, gain);
  const auto limit = hn::Set(df, band);
  const auto low_byte = hn::Set(d, 0xFF);
  const auto below_darkest = hn::Set(d, usable.darkest - 1);
  const auto above_brightest = hn::Set(d, usable.brightest + 1);
  const auto black = hn::Set(d, 1);
  const auto saturated = hn::Set(d, usable.saturated);
  const auto saturated_float = hn::Set(df, static_cast<float>(usable.saturated));
  Agreement out;
  std::uint64_t sum_lb = 0, sum_bb = 0, sum_ll = 0;
  std::size_t s = 0;
  while (count - s >= n) {
    // Each lane sums at most 65025 a sample in 32 bits: 2^16 vectors a block fit.
    const std::size_t block_end = s + std::min<std::size_t>((count - s) / n, 65536) * n;
    auto lb = hn::Zero(du), bb = hn::Zero(du), ll = hn::Zero(du);
    auto used_lanes = hn::Zero(du), agreeing_lanes = hn::Zero(du), clipped_lanes = hn::Zero(du);
    for (; s < block_end; s += n) {
      const auto pair = hn::PromoteTo(d, hn::LoadU(d16, samples + s));
      const auto b = hn::ShiftRight<8>(pair);
      const auto l = hn::And(pair, low_byte);
      const auto used = hn::And(hn::And(hn::Gt(b, below_darkest), hn::Lt(b, above_brightest)),
                                hn::And(hn::Gt(l, black), hn::Lt(l, saturated)));
      const auto expected = hn::Mul(g, hn::ConvertTo(df, b));
      const auto error = hn::Abs(hn::Sub(hn::ConvertTo(df, l), expected));
      const auto agree = hn::And(used, hn::RebindMask(d, hn::Lt(error, limit)));
      const auto clipped =
          hn::And(hn::And(hn::Gt(b, below_darkest), hn::Not(hn::Lt(l, saturated))),
                  hn::RebindMask(d, hn::Ge(hn::Add(expected, limit), saturated_float)));
      clipped_lanes = hn::Sub(clipped_lanes, hn::BitCast(du, hn::VecFromMask(d, clipped)));
      lb = hn::Add(lb, hn::BitCast(du, hn::IfThenElseZero(agree, hn::Mul(l, b))));
      bb = hn::Add(bb, hn::BitCast(du, hn::IfThenElseZero(agree, hn::Mul(b, b))));
      ll = hn::Add(ll, hn::BitCast(du, hn::IfThenElseZero(agree, hn::Mul(l, l))));
      // Counted in lanes too (a true mask lane is all ones: minus one), not per vector.
      used_lanes = hn::Sub(used_lanes, hn::BitCast(du, hn::VecFromMask(d, used)));
      agreeing_lanes = hn::Sub(agreeing_lanes, hn::BitCast(du, hn::VecFromMask(d, agree)));
    }
    // The block's lanes, summed in 64 bits.
    std::uint32_t lanes[hn::MaxLanes(du)];
    const auto add = [&](const auto& sums, auto& total) {
      hn::StoreU(sums, du, lanes);
      for (std::size_t i = 0; i < n; ++i) total += lanes[i];
    };
    add(lb, sum_lb);
    add(bb, sum_bb);
    add(ll, sum_ll);
    add(used_lanes, out.usable);
    add(agreeing_lanes, out.agreeing);
    add(clipped_lanes, out.clipped);
  }
  const Agreement tail = agreementScalar(samples + s, count - s, gain, band, usable);
  out.sum_lb = static_cast<double>(sum_lb) + tail.sum_lb;
  out.sum_bb = static_cast<double>(sum_bb) + tail.sum_bb;
  out.sum_ll = static_cast<double>(sum_ll) + tail.sum_ll;
  out.usable += tail.usable;
  out.agreeing += tail.agreeing;
  out.clipped += tail.clipped;
  return out;
}

TileSums tileSumsVector(const std::uint8_t* HWY_RESTRICT frame, std::ptrdiff_t frame_stride,
                        const std::uint8_t* HWY_RESTRICT background,
                        std::ptrdiff_t background_stride, int width, int height, int saturated) {
  // A whole tile's row is 8 pixels: in 8 lanes of 32 bits where the target has them, else in two
  // halves. Tiles cut by the image's edge go the scalar way.
  const hn::CappedTag<std::int32_t, 8> d;
  const hn::Rebind<std::uint8_t, decltype(d)> bytes;
  const std::size_t n = hn::Lanes(d);
  if (width != 8 || 8 % n != 0) {
    return tileSumsScalar(frame, frame_stride, background, background_stride, width, height,
                          saturated);
  }
  const auto clipped = hn::Set(d, saturated);
  const auto one = hn::Set(d, 1);
  // At most 64 pixels of 255² each: the sums fit 32 bits.
  auto count = hn::Zero(d);
  auto sum_b = hn::Zero(d);
  auto sum_bb = hn::Zero(d);
  auto sum_lb = hn::Zero(d);
  auto sum_ll = hn::Zero(d);
  for (int v = 0; v < height; ++v) {
    const std::uint8_t* l_row = frame + v * frame_stride;
    const std::uint8_t* b_row = background + v * background_stride;
    for (std::size_t u = 0; u < 8; u += n) {
      const auto l = hn::PromoteTo(d, hn::LoadU(bytes, l_row + u));
      const auto b = hn::PromoteTo(d, hn::LoadU(bytes, b_row + u));
      const auto measured = hn::Lt(l, clipped);  // a clipped pixel does not measure the gain
      count = hn::Add(count, hn::IfThenElseZero(measured, one));
      sum_b = hn::Add(sum_b, hn::IfThenElseZero(measured, b));
      sum_bb = hn::Add(sum_bb, hn::IfThenElseZero(measured, hn::Mul(b, b)));
      sum_lb = hn::Add(sum_lb, hn::IfThenElseZero(measured, hn::Mul(l, b)));
      sum_ll = hn::Add(sum_ll, hn::IfThenElseZero(measured, hn::Mul(l, l)));
    }
  }
  const auto total = [&](auto sums) {
    return static_cast<std::uint32_t>(hn::GetLane(hn::SumOfLanes(d, sums)));
  };
  return {total(count), total(sum_b), total(sum_bb), total(sum_lb), total(sum_ll)};
}

CorrelationSums correlationSumsVector(const std::uint8_t* HWY_RESTRICT b,
                                      const std::uint8_t* HWY_RESTRICT l, std::size_t count) {
  // 32-bit lanes: each adds at most count / lanes products of 255² (at most 65536 / 4 of them,
  // under 2^31).
  const WideTag d;
  const hn::Rebind<std::uint8_t, WideTag> bytes;
  const std::size_t n = hn::Lanes(d);
  auto sum_b = hn::Zero(d);
  auto sum_l = hn::Zero(d);
  auto sum_bb = hn::Zero(d);
  auto sum_ll = hn::Zero(d);
  auto sum_bl = hn::Zero(d);
  std::size_t u = 0;
  for (; u + n <= count; u += n) {
    const auto bv = hn::PromoteTo(d, hn::LoadU(bytes, b + u));
    const auto lv = hn::PromoteTo(d, hn::LoadU(bytes, l + u));
    sum_b = hn::Add(sum_b, bv);
    sum_l = hn::Add(sum_l, lv);
    sum_bb = hn::Add(sum_bb, hn::Mul(bv, bv));
    sum_ll = hn::Add(sum_ll, hn::Mul(lv, lv));
    sum_bl = hn::Add(sum_bl, hn::Mul(bv, lv));
  }
  const auto total = [&](auto sums) {
    return static_cast<std::uint64_t>(hn::GetLane(hn::SumOfLanes(d, sums)));
  };
  CorrelationSums sums = correlationSumsScalar(b + u, l + u, count - u);
  sums.sum_b += total(sum_b);
  sums.sum_l += total(sum_l);
  sums.sum_bb += total(sum_bb);
  sums.sum_ll += total(sum_ll);
  sums.sum_bl += total(sum_bl);
  return sums;
}

}  // namespace occmap::lighting_steps::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace occmap::lighting_steps {

HWY_EXPORT(inBackgroundsLightVector);
HWY_EXPORT(atMostVector);
HWY_EXPORT(driftRowVector);
HWY_EXPORT(samplePairsVector);
HWY_EXPORT(agreementVector);
HWY_EXPORT(tileSumsVector);
HWY_EXPORT(correlationSumsVector);

void inBackgroundsLight(const std::uint8_t* live, int width, std::int32_t inverse_q16,
                        std::uint8_t* out) {
  HWY_DYNAMIC_DISPATCH(inBackgroundsLightVector)(live, width, inverse_q16, out);
}

void atMost(const std::uint8_t* in, std::size_t count, std::uint8_t cap, std::uint8_t* out) {
  HWY_DYNAMIC_DISPATCH(atMostVector)(in, count, cap, out);
}

void driftRow(const std::uint8_t* live, const std::uint8_t* quiet, int width,
              std::int32_t inverse_q16, std::int32_t alpha_q16, int saturated, std::uint16_t* fine,
              std::uint8_t* grey) {
  HWY_DYNAMIC_DISPATCH(driftRowVector)
  (live, quiet, width, inverse_q16, alpha_q16, saturated, fine, grey);
}

void samplePairs(const std::uint8_t* background, const std::uint8_t* live, int width,
                 std::uint16_t* pairs) {
  HWY_DYNAMIC_DISPATCH(samplePairsVector)(background, live, width, pairs);
}

void samplePairsScalar(const std::uint8_t* background, const std::uint8_t* live, int width,
                       std::uint16_t* pairs) {
  for (int u = 0; u < width; u += 4) {
    pairs[u / 4] = static_cast<std::uint16_t>(background[u] << 8 | live[u]);
  }
}

Agreement agreement(const std::uint16_t* samples, std::size_t count, float gain, float band,
                    Usable usable) {
  return HWY_DYNAMIC_DISPATCH(agreementVector)(samples, count, gain, band, usable);
}

Agreement agreementScalar(const std::uint16_t* samples, std::size_t count, float gain, float band,
                          Usable usable) {
  Agreement out;
  std::uint64_t sum_lb = 0, sum_bb = 0, sum_ll = 0;
  for (std::size_t s = 0; s < count; ++s) {
    out.clipped += clippedAsTheLightSays(samples[s], gain, band, usable) ? 1 : 0;
    if (!usableSample(samples[s], usable)) continue;
    ++out.usable;
    if (!agrees(samples[s], gain, band)) continue;
    const std::uint64_t b = samples[s] >> 8;
    const std::uint64_t l = samples[s] & 0xFF;
    ++out.agreeing;
    sum_lb += l * b;
    sum_bb += b * b;
    sum_ll += l * l;
  }
  out.sum_lb = static_cast<double>(sum_lb);
  out.sum_bb = static_cast<double>(sum_bb);
  out.sum_ll = static_cast<double>(sum_ll);
  return out;
}

TileSums tileSums(const std::uint8_t* frame, std::ptrdiff_t frame_stride,
                  const std::uint8_t* background, std::ptrdiff_t background_stride, int width,
                  int height, int saturated) {
  return HWY_DYNAMIC_DISPATCH(tileSumsVector)(frame, frame_stride, background, background_stride,
                                              width, height, saturated);
}

TileSums tileSumsScalar(const std::uint8_t* frame, std::ptrdiff_t frame_stride,
                        const std::uint8_t* background, std::ptrdiff_t background_stride, int width,
                        int height, int saturated) {
  TileSums sums;
  for (int v = 0; v < height; ++v) {
    const std::uint8_t* l = frame + v * frame_stride;
    const std::uint8_t* b = background + v * background_stride;
    for (int u = 0; u < width; ++u) {
      if (l[u] >= saturated) continue;  // clipped: no measure of the gain
      ++sums.count;
      sums.sum_b += b[u];
      sums.sum_bb += static_cast<std::uint32_t>(b[u]) * b[u];
      sums.sum_lb += static_cast<std::uint32_t>(l[u]) * b[u];
      sums.sum_ll += static_cast<std::uint32_t>(l[u]) * l[u];
    }
  }
  return sums;
}

void inBackgroundsLightScalar(const std::uint8_t* live, int width, std::int32_t inverse_q16,
                              std::uint8_t* out) {
  for (int u = 0; u < width; ++u) {
    out[u] = static_cast<std::uint8_t>(std::min(255, (live[u] * inverse_q16 + 32768) >> 16));
  }
}

void driftRowScalar(const std::uint8_t* live, const std::uint8_t* quiet, int width,
                    std::int32_t inverse_q16, std::int32_t alpha_q16, int saturated,
                    std::uint16_t* fine, std::uint8_t* grey) {
  for (int u = 0; u < width; ++u) {
    const std::int32_t l = live[u];
    const std::int32_t target = std::min(65535, (l * inverse_q16 + 128) >> 8);
    const std::int32_t now = fine[u];
    const std::int32_t difference = target - now;
    std::int32_t step = (difference * alpha_q16) >> 16;  // toward -inf: -1 at least below
    step += (step == 0 && difference > 0) ? 1 : 0;       // and +1 at least above
    // A clipped pixel says only "at least this bright": nothing to learn from it.
    const bool learn = quiet[u] != 0 && l < saturated;
    const std::int32_t moved = learn ? now + step : now;
    fine[u] = static_cast<std::uint16_t>(moved);
    grey[u] = static_cast<std::uint8_t>(std::min(255, (moved + 128) >> 8));
  }
}

CorrelationSums correlationSums(const std::uint8_t* b, const std::uint8_t* l, std::size_t count) {
  return HWY_DYNAMIC_DISPATCH(correlationSumsVector)(b, l, count);
}

CorrelationSums correlationSumsScalar(const std::uint8_t* b, const std::uint8_t* l,
                                      std::size_t count) {
  CorrelationSums sums;
  for (std::size_t u = 0; u < count; ++u) {
    const std::uint64_t bu = b[u];
    const std::uint64_t lu = l[u];
    sums.sum_b += bu;
    sums.sum_l += lu;
    sums.sum_bb += bu * bu;
    sums.sum_ll += lu * lu;
    sums.sum_bl += bu * lu;
  }
  return sums;
}

}  // namespace occmap::lighting_steps
#endif  // HWY_ONCE
