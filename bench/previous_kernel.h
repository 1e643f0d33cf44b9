#pragma once
// The pipeline's kernel before the SIMD kernels (issue 3), kept as the "before" of the benchmarks:
// a changed byte per pixel, and per camera a walk of the pixels through a pixel -> cells table,
// storing into the map or into per-cell stamps.

#include <cstdint>
#include <span>
#include <vector>

#include "core/carve_table.h"
#include "core/image.h"
#include "core/map_geometry.h"

namespace occmap::bench {

class PreviousKernel {
 public:
  explicit PreviousKernel(std::span<const CarveTable> tables);

  // One byte per pixel, 1 = changed (eqs. 14-15).
  static void markChangedPixels(ImageView live, ImageView background, int threshold,
                                std::uint8_t* changed);
  void fuse(std::span<const std::uint8_t* const> changed, std::span<CellState> out);

 private:
  struct CameraTable {
    CarveRule rule;
    std::vector<std::uint32_t> pixel_offsets;  // per stream pixel + 1 (CSR)
    std::vector<std::uint32_t> pixel_cells;    // cells each pixel decides
    std::vector<std::uint32_t> seen_cells;     // cells the camera sees, ascending
  };

  std::vector<CameraTable> cameras_;
  std::vector<std::uint64_t> seen_by_;  // per cell: bit k when camera k sees it
  std::vector<std::uint32_t> blocked_;  // per cell: stamp of the last frame that blocked it
  std::uint32_t stamp_ = 0;
};

}  // namespace occmap::bench
