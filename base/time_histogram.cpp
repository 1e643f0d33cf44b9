#include "base/time_histogram.h"

#include <algorithm>

namespace occmap {

void TimeHistogram::record(std::int64_t ns) {
  const std::int64_t bin = std::clamp<std::int64_t>(ns / 10'000, 0, kBins - 1);
  bins_[bin].fetch_add(1, std::memory_order_relaxed);
  count_.fetch_add(1, std::memory_order_relaxed);
  if (ns > max_ns_.load(std::memory_order_relaxed)) max_ns_.store(ns, std::memory_order_relaxed);
}

double TimeHistogram::percentileMs(double fraction) const {
  std::uint64_t total = 0;
  for (const auto& bin : bins_) total += bin.load(std::memory_order_relaxed);
  if (total == 0) return 0.0;
  const auto rank = static_cast<std::uint64_t>(fraction * static_cast<double>(total - 1));
  std::uint64_t seen = 0;
  for (int i = 0; i < kBins; ++i) {
    seen += bins_[i].load(std::memory_order_relaxed);
    if (seen > rank) return (i + 0.5) * 0.01;  // the bin's middle, in ms
  }
  return kBins * 0.01;
}

}  // namespace occmap
