#include <algorithm>

#include "bench/baselines.h"

namespace occmap::bench {

void paperLoop(std::span<const ImageView> live, std::span<const ImageView> background,
               const std::vector<std::vector<std::int32_t>>& table, int threshold,
               std::span<std::uint8_t> map) {
  std::fill(map.begin(), map.end(), std::uint8_t{1});
  for (std::size_t c = 0; c < live.size(); ++c) {
    const std::int32_t* f = table[c].data();
    for (int v = 0; v < live[c].height; ++v) {
      const std::uint8_t* a = live[c].row(v);
      const std::uint8_t* b = background[c].row(v);
      const std::int32_t* f_row = f + static_cast<std::ptrdiff_t>(v) * live[c].width;
      for (int u = 0; u < live[c].width; ++u) {
        const int difference = a[u] - b[u];
        if ((difference < 0 ? -difference : difference) < threshold && f_row[u] >= 0) {
          map[static_cast<std::size_t>(f_row[u])] = 0;
        }
      }
    }
  }
}

}  // namespace occmap::bench
