#include "core/background_median.h"

#include <algorithm>
#include <stdexcept>
#include <vector>

namespace occmap {

Image backgroundMedian(std::span<const std::uint8_t> frames, int count, int width, int height) {
  const std::size_t pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (count < 1 || frames.size() != pixels * static_cast<std::size_t>(count)) {
    throw std::invalid_argument("backgroundMedian: the frames are not count x width x height");
  }
  Image median(width, height);
  // All frames are kept and each pixel's median picked out: exact, and cheap for the tens to
  // hundreds of frames this is for.
  std::vector<std::uint8_t> values(static_cast<std::size_t>(count));
  for (std::size_t p = 0; p < pixels; ++p) {
    for (int k = 0; k < count; ++k) {
      values[static_cast<std::size_t>(k)] = frames[static_cast<std::size_t>(k) * pixels + p];
    }
    const auto middle = values.begin() + count / 2;
    std::nth_element(values.begin(), middle, values.end());
    median.data()[p] = *middle;
  }
  return median;
}

}  // namespace occmap
