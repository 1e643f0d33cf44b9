#pragma once
// The two yardsticks the kernels are measured against, in the same run.

#include <cstdint>
#include <span>
#include <vector>

#include "core/image.h"

namespace occmap::bench {

// The paper's loop (section 3.2) as its pseudo-code has it, in plain scalar C++: the map starts
// occupied (1), and every pixel whose difference is under the threshold (eqs. 14-15) clears the
// cell its centre's ray meets, through the pixel-centre table F (-1: no cell). Images are walked in
// memory order (rows outside, as any C version would), the paper's loops being over u, then v.
void paperLoop(std::span<const ImageView> live, std::span<const ImageView> background,
               const std::vector<std::vector<std::int32_t>>& table, int threshold,
               std::span<std::uint8_t> map);

// What no kernel that reads the images can beat: every live and background byte read once and
// summed, SIMD through Highway (dispatched like the kernels).
std::uint64_t memoryBound(std::span<const ImageView> live, std::span<const ImageView> background);

}  // namespace occmap::bench
