#include "bench/previous_kernel.h"

#include <algorithm>

namespace occmap::bench {

void PreviousKernel::markChangedPixels(ImageView live, ImageView background, int threshold,
                                       std::uint8_t* changed) {
  for (int v = 0; v < live.height; ++v) {
    const std::uint8_t* a = live.row(v);
    const std::uint8_t* b = background.row(v);
    std::uint8_t* out = changed + static_cast<std::ptrdiff_t>(v) * live.width;
    for (int u = 0; u < live.width; ++u) {
      const int difference = int{a[u]} - int{b[u]};
      out[u] = (difference < 0 ? -difference : difference) >= threshold ? 1 : 0;
    }
  }
}

PreviousKernel::PreviousKernel(std::span<const CarveTable> tables) {
  const std::size_t cells = tables.empty() ? 0 : tables.front().map().cellCount();
  seen_by_.assign(cells, 0);
  blocked_.assign(cells, 0);
  for (std::size_t k = 0; k < tables.size(); ++k) {
    const CarveTable& table = tables[k];
    // Transpose the table (cell -> pixels) into pixel -> cells: the walk follows the image.
    const std::size_t pixels = static_cast<std::size_t>(table.imageWidth()) *
                               static_cast<std::size_t>(table.imageHeight());
    CameraTable camera{table.rule(), std::vector<std::uint32_t>(pixels + 1, 0), {}, {}};
    for (std::size_t cell = 0; cell < cells; ++cell) {
      for (const std::uint32_t pixel : table.pixelsOf(cell)) ++camera.pixel_offsets[pixel + 1];
      if (table.sees(cell)) {
        camera.seen_cells.push_back(static_cast<std::uint32_t>(cell));
        seen_by_[cell] |= std::uint64_t{1} << k;
      }
    }
    for (std::size_t p = 1; p <= pixels; ++p) {
      camera.pixel_offsets[p] += camera.pixel_offsets[p - 1];
    }
    camera.pixel_cells.resize(camera.pixel_offsets[pixels]);
    std::vector<std::uint32_t> fill(camera.pixel_offsets.begin(), camera.pixel_offsets.end() - 1);
    for (std::size_t cell = 0; cell < cells; ++cell) {
      for (const std::uint32_t pixel : table.pixelsOf(cell)) {
        camera.pixel_cells[fill[pixel]++] = static_cast<std::uint32_t>(cell);
      }
    }
    cameras_.push_back(std::move(camera));
  }
}

void PreviousKernel::fuse(std::span<const std::uint8_t* const> changed, std::span<CellState> out) {
  std::uint64_t live = 0;
  for (std::size_t k = 0; k < changed.size(); ++k) {
    if (changed[k] != nullptr) live |= std::uint64_t{1} << k;
  }
  for (std::size_t cell = 0; cell < out.size(); ++cell) {
    out[cell] = (seen_by_[cell] & live) != 0 ? CellState::kOccupied : CellState::kUnseen;
  }
  for (std::size_t k = 0; k < cameras_.size(); ++k) {
    const std::uint8_t* mask = changed[k];
    if (mask == nullptr) continue;
    const CameraTable& camera = cameras_[k];
    const std::uint32_t* offsets = camera.pixel_offsets.data();
    const std::uint32_t* cells = camera.pixel_cells.data();
    const std::size_t pixels = camera.pixel_offsets.size() - 1;
    if (camera.rule == CarveRule::kAnyPixel) {
      for (std::size_t p = 0; p < pixels; ++p) {
        if (mask[p]) continue;
        for (std::uint32_t i = offsets[p]; i < offsets[p + 1]; ++i)
          out[cells[i]] = CellState::kFree;
      }
      continue;
    }
    if (++stamp_ == 0) {
      std::fill(blocked_.begin(), blocked_.end(), 0);
      stamp_ = 1;
    }
    for (std::size_t p = 0; p < pixels; ++p) {
      if (!mask[p]) continue;
      for (std::uint32_t i = offsets[p]; i < offsets[p + 1]; ++i) blocked_[cells[i]] = stamp_;
    }
    for (const std::uint32_t cell : camera.seen_cells) {
      if (blocked_[cell] != stamp_) out[cell] = CellState::kFree;
    }
  }
}

}  // namespace occmap::bench
