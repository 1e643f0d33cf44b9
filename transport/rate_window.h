#pragma once
// Rates for the status messages (status_t, merge_status_t): maps published a second, and one
// count a second per part (a camera's frames, a merge input's maps), measured over the last few
// periodic statuses, since one period alone is too short to be steady. A fixed ring of samples,
// the oldest at `oldest_`, filled in place: nothing is allocated once made.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace occmap {

class RateWindow {
 public:
  static constexpr std::size_t kSamples = 5;

  // `parts` counts besides the maps; `now_ns` (CLOCK_MONOTONIC) starts the window.
  RateWindow(std::size_t parts, std::int64_t now_ns)
      : samples_(kSamples, Sample{now_ns, 0, std::vector<std::uint64_t>(parts)}) {}

  std::size_t parts() const { return samples_[0].counts.size(); }
  // Per second since the oldest sample, up to now_ns: the maps published and part k's count.
  double mapsPerSecond(std::uint64_t published, std::int64_t now_ns) const {
    return static_cast<double>(published - oldest().published) / seconds(now_ns);
  }
  double perSecond(std::size_t part, std::uint64_t count, std::int64_t now_ns) const {
    return static_cast<double>(count - oldest().counts[part]) / seconds(now_ns);
  }
  // The oldest sample makes way for this one (the ring starts with copies of the start): the
  // periodic status's, not an answer to a request. count(k) gives part k's count.
  template <class Count>
  void moveOn(std::int64_t now_ns, std::uint64_t published, Count count) {
    Sample& sample = samples_[oldest_];
    sample.ns = now_ns;
    sample.published = published;
    for (std::size_t k = 0; k < sample.counts.size(); ++k) sample.counts[k] = count(k);
    oldest_ = (oldest_ + 1) % kSamples;
  }

 private:
  struct Sample {
    std::int64_t ns = 0;
    std::uint64_t published = 0;
    std::vector<std::uint64_t> counts;
  };
  const Sample& oldest() const { return samples_[oldest_]; }
  double seconds(std::int64_t now_ns) const {
    return std::max(1e-3, static_cast<double>(now_ns - oldest().ns) / 1e9);
  }

  std::vector<Sample> samples_;
  std::size_t oldest_ = 0;
};

}  // namespace occmap
