// memoryBound, compiled once per SIMD target (Highway's foreach_target) and dispatched at run time.
#include "bench/baselines.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "bench/memory_bound.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
// foreach_target.h must come first.
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace occmap::bench::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Sums of 8 bytes into 64-bit lanes, four vectors at a time so that the loads, not the adds'
// latency, set the pace.
std::uint64_t sumBytes(const std::uint8_t* HWY_RESTRICT bytes, std::size_t count) {
  const hn::ScalableTag<std::uint8_t> d8;
  const hn::Repartition<std::uint64_t, decltype(d8)> d64;
  const std::size_t n = hn::Lanes(d8);
  auto s0 = hn::Zero(d64), s1 = hn::Zero(d64), s2 = hn::Zero(d64), s3 = hn::Zero(d64);
  std::size_t i = 0;
  for (; i + 4 * n <= count; i += 4 * n) {
    s0 = hn::Add(s0, hn::SumsOf8(hn::LoadU(d8, bytes + i)));
    s1 = hn::Add(s1, hn::SumsOf8(hn::LoadU(d8, bytes + i + n)));
    s2 = hn::Add(s2, hn::SumsOf8(hn::LoadU(d8, bytes + i + 2 * n)));
    s3 = hn::Add(s3, hn::SumsOf8(hn::LoadU(d8, bytes + i + 3 * n)));
  }
  for (; i + n <= count; i += n) s0 = hn::Add(s0, hn::SumsOf8(hn::LoadU(d8, bytes + i)));
  std::uint64_t sum = hn::GetLane(hn::SumOfLanes(d64, hn::Add(hn::Add(s0, s1), hn::Add(s2, s3))));
  for (; i < count; ++i) sum += bytes[i];
  return sum;
}

}  // namespace occmap::bench::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace occmap::bench {

HWY_EXPORT(sumBytes);

std::uint64_t memoryBound(std::span<const ImageView> live, std::span<const ImageView> background) {
  std::uint64_t sum = 0;
  for (const std::span<const ImageView> images : {live, background}) {
    for (const ImageView& image : images) {
      if (image.stride == image.width) {  // packed rows: one stream
        sum +=
            HWY_DYNAMIC_DISPATCH(sumBytes)(image.data, static_cast<std::size_t>(image.width) *
                                                           static_cast<std::size_t>(image.height));
        continue;
      }
      for (int v = 0; v < image.height; ++v) {
        sum += HWY_DYNAMIC_DISPATCH(sumBytes)(image.row(v), static_cast<std::size_t>(image.width));
      }
    }
  }
  return sum;
}

}  // namespace occmap::bench
#endif  // HWY_ONCE
