#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "core/carve_table.h"
#include "core/image.h"
#include "core/map_geometry.h"

namespace occmap {

// The paper's difference (eqs. 14-15) for one camera frame: 1 where |live - background| >=
// threshold (changed: no clear ray), 0 where unchanged. This is the capture threads' share of the
// work, done while the pixels are hot. `changed` has width * height bytes.
void markChangedPixels(ImageView live, ImageView background, int threshold, std::uint8_t* changed);

// The fusion as the pipeline runs it: one look-up-table walk per camera, from pixels to the cells
// they decide, equal cell for cell to fuseReference (tests hold it to that). Built once from the
// carve tables; fuse() allocates nothing.
//
// Floor mode (any pixel clears): every unchanged pixel frees its cells. Column mode (every pixel
// must be unchanged): every changed pixel blocks its cells for this camera; the camera frees the
// cells it sees that nothing blocked.
class FusionKernel {
 public:
  static constexpr std::size_t kMaxCameras = 64;

  // Throws std::invalid_argument for more than kMaxCameras tables or tables of different maps.
  explicit FusionKernel(std::span<const CarveTable> tables);

  // changed[k]: camera k's changed-pixel mask (markChangedPixels), or nullptr when camera k is not
  // in this frame set (down or late): then its cells count only if another camera sees them.
  // `out` has the map's cell count.
  void fuse(std::span<const std::uint8_t* const> changed, std::span<CellState> out);

  std::size_t cameraCount() const { return cameras_.size(); }

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

}  // namespace occmap
