#include "core/fusion_kernel.h"

#include <algorithm>
#include <bit>
#include <stdexcept>
#include <utility>

#include "core/fusion_steps.h"

namespace occmap {
namespace {

// writeCellStates computes the states as numbers: 2 - seen - free.
static_assert(static_cast<int>(CellState::kFree) == 0 &&
              static_cast<int>(CellState::kOccupied) == 1 &&
              static_cast<int>(CellState::kUnseen) == 2);

enum List { kOne, kSeveral, kTwoTiles, kSpread, kLists };

// One entry of a camera's tile lists before they are laid out: a cell under a tile.
struct Entry {
  std::uint32_t tile;
  std::uint32_t cell;
  std::uint64_t pixels;  // kOne, kSeveral: the cell's pixels in the tile
  List list;
  std::uint32_t piece_first;  // kSpread: the cell's (tile, pixels) pieces
  std::uint32_t piece_count;
  std::uint32_t other_tile;  // kTwoTiles: the other tile and the cell's pixels there
  std::uint64_t other_pixels;
};

// Fills in one list's starts (`starts` has a record per tile of `tiles`, + 1) from per-tile
// counts; returns the entry count and leaves in `next` where each tile's entries start.
std::uint32_t layOut(const std::vector<std::uint32_t>& tiles,
                     const std::vector<std::uint32_t>& count,
                     std::uint32_t fusion_steps::TileStart::*list,
                     std::vector<fusion_steps::TileStart>& starts,
                     std::vector<std::uint32_t>& next) {
  std::uint32_t entries = 0;
  for (std::size_t i = 0; i < tiles.size(); ++i) {
    starts[i].*list = entries;
    next[tiles[i]] = entries;
    entries += count[tiles[i]];
  }
  starts[tiles.size()].*list = entries;
  return entries;
}

}  // namespace

std::size_t changedMaskBytes(int width, int height) {
  return tilesAcross(width) * tilesDown(height) * 8;
}

void markChangedPixels(ImageView live, ImageView background, int threshold, std::uint8_t* changed,
                       KernelPath path) {
  // The vector code compares against threshold - 1 in a byte; the rest (every pixel changed, or
  // none) is left to the scalar code, which handles any threshold.
  if (path == KernelPath::kSimd && threshold >= 1 && threshold <= 255) {
    fusion_steps::markChangedTiles(live, background, threshold, nullptr, changed);
  } else {
    fusion_steps::markChangedTilesScalar(live, background, threshold, nullptr, changed);
  }
}

std::uint32_t FusionKernel::markChangedPixels(std::size_t k, ImageView live, ImageView background,
                                              int threshold, std::uint8_t* changed) const {
  const std::shared_ptr<const CameraTable> table =
      cameras_.at(k).table.load(std::memory_order_acquire);
  const CameraTable& camera = *table;
  for (const ImageView* image : {&live, &background}) {
    if (image->width != camera.image_width || image->height != camera.image_height) {
      throw std::invalid_argument("markChangedPixels: image size differs from the table's");
    }
  }
  if (path_ == KernelPath::kSimd && threshold >= 1 && threshold <= 255) {
    fusion_steps::markChangedTiles(live, background, threshold, camera.needed_strips.data(),
                                   changed);
  } else {
    fusion_steps::markChangedTilesScalar(live, background, threshold, camera.needed_strips.data(),
                                         changed);
  }
  return camera.generation;
}

FusionKernel::Replacement FusionKernel::prepareReplacement(const CarveTable& table) {
  Replacement out;
  out.table_ = std::make_shared<CameraTable>(turnAround(table));
  return out;
}

void FusionKernel::replaceCamera(std::size_t k, Replacement prepared) {
  const std::shared_ptr<const CameraTable> old =
      cameras_.at(k).table.load(std::memory_order_acquire);
  std::shared_ptr<CameraTable> replacement = std::move(prepared.table_);
  if (!replacement || replacement->cells != cell_count_) {
    throw std::invalid_argument("replaceCamera: a carve table of another map");
  }
  if (replacement->image_width != old->image_width ||
      replacement->image_height != old->image_height) {
    throw std::invalid_argument("replaceCamera: a carve table of another image size");
  }
  replacement->generation = old->generation + 1;
  // Release: the table is whole before a reader can load it.
  cameras_[k].table.store(std::move(replacement), std::memory_order_release);
}

std::uint32_t FusionKernel::generation(std::size_t k) const {
  return cameras_.at(k).table.load(std::memory_order_acquire)->generation;
}

FusionKernel::FusionKernel(std::span<const CarveTable> tables, KernelPath path) : path_(path) {
  if (tables.size() > kMaxCameras) {
    throw std::invalid_argument("the fusion kernel takes at most 64 cameras");
  }
  cell_count_ = tables.empty() ? 0 : tables.front().map().cellCount();
  if (cell_count_ >= std::size_t{0xFFFFFFFF}) {
    throw std::invalid_argument("the fusion kernel takes maps of fewer than 2^32 - 1 cells");
  }
  const std::size_t words = (cell_count_ + 63) / 64;
  // One stamp per cell, then the sink that stores for cells not blocked go to (no branch per
  // entry), padded to whole words.
  blocked_.assign((words + 1) * 64, 0);
  free_.assign(words, 0);
  seen_.assign(words, 0);
  cameras_ = std::vector<CameraSlot>(tables.size());
  fusing_.resize(tables.size());
  for (std::size_t k = 0; k < tables.size(); ++k) {
    if (tables[k].map().cellCount() != cell_count_) {
      throw std::invalid_argument("carve tables of different maps");
    }
    auto camera = std::make_shared<const CameraTable>(turnAround(tables[k]));
    changed_tiles_.resize(std::max(changed_tiles_.size(), camera->tiles.size()));
    cameras_[k].table.store(std::move(camera), std::memory_order_release);
  }
}

// Cell -> pixels becomes tile -> (cell, the cell's pixels in the tile).
FusionKernel::CameraTable FusionKernel::turnAround(const CarveTable& table) {
  const std::size_t cells = table.map().cellCount();
  CameraTable camera;
  camera.cells = cells;
  camera.rule = table.rule();
  camera.image_width = table.imageWidth();
  camera.image_height = table.imageHeight();
  camera.seen.assign((cells + 63) / 64, 0);
  const auto width = static_cast<std::uint32_t>(table.imageWidth());
  const auto across = static_cast<std::uint32_t>(tilesAcross(table.imageWidth()));
  const std::size_t tile_count = tilesAcross(table.imageWidth()) * tilesDown(table.imageHeight());
  std::vector<Entry> entries;                                   // in cell order
  std::vector<std::pair<std::uint32_t, std::uint64_t>> pieces;  // spread cells' tiles and pixels
  std::vector<std::pair<std::uint32_t, std::uint64_t>> groups;  // one cell's tiles and pixels
  for (std::size_t cell = 0; cell < cells; ++cell) {
    if (!table.sees(cell)) continue;
    camera.seen[cell / 64] |= std::uint64_t{1} << (cell % 64);
    groups.clear();
    for (const std::uint32_t pixel : table.pixelsOf(cell)) {
      const std::uint32_t u = pixel % width, v = pixel / width;
      const std::uint32_t tile = v / 8 * across + u / 8;
      const std::uint64_t bit = std::uint64_t{1} << (v % 8 * 8 + u % 8);
      auto group = std::find_if(groups.rbegin(), groups.rend(),
                                [&](const auto& g) { return g.first == tile; });
      if (group != groups.rend()) {
        group->second |= bit;
      } else {
        groups.emplace_back(tile, bit);
      }
    }
    const auto c = static_cast<std::uint32_t>(cell);
    if (camera.rule == CarveRule::kAnyPixel && groups.size() == 2) {
      entries.push_back({groups[0].first, c, groups[0].second, kTwoTiles, 0, 0, groups[1].first,
                         groups[1].second});
      continue;
    }
    if (camera.rule == CarveRule::kAnyPixel && groups.size() > 1) {
      // Floor carving blocks the cell only if all its pixels changed: one look at all its tiles,
      // from the first, is enough (if that one has no changed pixel, the cell is not blocked).
      entries.push_back({groups.front().first, c, 0, kSpread,
                         static_cast<std::uint32_t>(pieces.size()),
                         static_cast<std::uint32_t>(groups.size()), 0, 0});
      pieces.insert(pieces.end(), groups.begin(), groups.end());
      continue;
    }
    for (const auto& [tile, bits] : groups) {
      const bool one = std::popcount(bits) == 1;
      entries.push_back({tile, c, bits, one ? kOne : kSeveral, 0, 0, 0, 0});
    }
  }
  // Then tile -> cells, by counting.
  std::vector<std::vector<std::uint32_t>> count(kLists, std::vector<std::uint32_t>(tile_count, 0));
  for (const Entry& entry : entries) ++count[entry.list][entry.tile];
  const std::size_t strips_across = (static_cast<std::size_t>(table.imageWidth()) + 63) / 64;
  camera.needed_strips.assign(strips_across * tilesDown(table.imageHeight()), 0);
  for (std::size_t tile = 0; tile < tile_count; ++tile) {
    if (count[kOne][tile] + count[kSeveral][tile] + count[kTwoTiles][tile] + count[kSpread][tile] >
        0) {
      camera.tiles.push_back(static_cast<std::uint32_t>(tile));
      camera.needed_strips[tile / across * strips_across + tile % across / 8] = 1;
    }
  }
  std::vector<std::vector<std::uint32_t>> next(kLists, std::vector<std::uint32_t>(tile_count, 0));
  camera.starts.resize(camera.tiles.size() + 1);
  // The vector code reads whole vectors of a list past a tile's end: padding keeps that in the
  // array.
  constexpr std::size_t kPadding = fusion_steps::kListPadding;
  const std::uint32_t several =
      layOut(camera.tiles, count[kSeveral], &fusion_steps::TileStart::several, camera.starts,
             next[kSeveral]);
  camera.several.pixels.resize(several + kPadding);
  camera.several.cells.resize(several + kPadding);
  const std::uint32_t two = layOut(camera.tiles, count[kTwoTiles], &fusion_steps::TileStart::two,
                                   camera.starts, next[kTwoTiles]);
  camera.two.cells.resize(two);
  camera.two.other_tiles.resize(two);
  camera.two.pixels.resize(std::size_t{two} * 2);
  const std::uint32_t spread = layOut(
      camera.tiles, count[kSpread], &fusion_steps::TileStart::spread, camera.starts, next[kSpread]);
  camera.spread.cells.resize(spread);
  std::vector<const Entry*> spread_entries(spread);
  // One-pixel cells, per tile in cell order, into windows of consecutive cells: each window starts
  // at the first cell the ones before it left.
  std::vector<std::vector<const Entry*>> one_pixel(tile_count);
  for (const Entry& entry : entries) {
    if (entry.list == kOne) one_pixel[entry.tile].push_back(&entry);
  }
  for (std::size_t i = 0; i < camera.tiles.size(); ++i) {
    camera.starts[i].one = static_cast<std::uint32_t>(camera.one.window_cells.size());
    const std::vector<const Entry*>& in_tile = one_pixel[camera.tiles[i]];
    for (std::size_t e = 0; e < in_tile.size();) {
      const std::uint32_t start = in_tile[e]->cell;
      camera.one.window_cells.push_back(start);
      const std::size_t window = camera.one.pixels.size();
      camera.one.pixels.resize(window + fusion_steps::kWindowCells, fusion_steps::kNoCell);
      for (; e < in_tile.size() && in_tile[e]->cell - start < fusion_steps::kWindowCells; ++e) {
        camera.one.pixels[window + in_tile[e]->cell - start] =
            fusion_steps::onePixelCode(static_cast<unsigned>(std::countr_zero(in_tile[e]->pixels)));
      }
    }
  }
  camera.starts.back().one = static_cast<std::uint32_t>(camera.one.window_cells.size());
  for (const Entry& entry : entries) {
    if (entry.list == kOne) continue;
    const std::uint32_t at = next[entry.list][entry.tile]++;
    switch (entry.list) {
      case kOne:
      case kLists:
        break;
      case kSeveral:
        camera.several.pixels[at] = entry.pixels;
        camera.several.cells[at] = entry.cell;
        break;
      case kTwoTiles:
        camera.two.cells[at] = entry.cell;
        camera.two.other_tiles[at] = entry.other_tile;
        camera.two.pixels[std::size_t{at} * 2] = entry.pixels;
        camera.two.pixels[std::size_t{at} * 2 + 1] = entry.other_pixels;
        break;
      case kSpread:
        camera.spread.cells[at] = entry.cell;
        spread_entries[at] = &entry;
        break;
    }
  }
  for (const Entry* entry : spread_entries) {
    camera.spread.pieces_first.push_back(
        static_cast<std::uint32_t>(camera.spread.piece_tiles.size()));
    for (std::uint32_t p = entry->piece_first; p < entry->piece_first + entry->piece_count; ++p) {
      camera.spread.piece_tiles.push_back(pieces[p].first);
      camera.spread.piece_pixels.push_back(pieces[p].second);
    }
  }
  camera.spread.pieces_first.push_back(
      static_cast<std::uint32_t>(camera.spread.piece_tiles.size()));
  const auto nonzero = [](std::uint64_t w) { return w != 0; };
  const auto first_seen = std::find_if(camera.seen.begin(), camera.seen.end(), nonzero);
  const auto last_seen = std::find_if(camera.seen.rbegin(), camera.seen.rend(), nonzero);
  camera.seen_begin = static_cast<std::size_t>(first_seen - camera.seen.begin());
  camera.seen_end =
      std::max(camera.seen_begin, static_cast<std::size_t>(camera.seen.rend() - last_seen));
  return camera;
}

std::size_t FusionKernel::tableBytes() const {
  std::size_t bytes = 0;
  auto add = [&](const auto& v) { bytes += v.size() * sizeof(v[0]); };
  for (const CameraSlot& slot : cameras_) {
    const std::shared_ptr<const CameraTable> table = slot.table.load(std::memory_order_acquire);
    const CameraTable& camera = *table;
    add(camera.needed_strips);
    add(camera.tiles);
    add(camera.starts);
    add(camera.one.window_cells);
    add(camera.one.pixels);
    add(camera.several.pixels);
    add(camera.several.cells);
    add(camera.two.cells);
    add(camera.two.other_tiles);
    add(camera.two.pixels);
    add(camera.spread.cells);
    add(camera.spread.pieces_first);
    add(camera.spread.piece_tiles);
    add(camera.spread.piece_pixels);
    add(camera.seen);
  }
  return bytes;
}

std::uint8_t FusionKernel::nextStamp() {
  if (++stamp_ == 0) {  // the stamps wrapped: forget every old one
    std::fill(blocked_.begin(), blocked_.end(), 0);
    stamp_ = 1;
  }
  return stamp_;
}

void FusionKernel::blockCells(const CameraTable& camera, const std::uint8_t* changed) {
  const fusion_steps::TileLists lists{camera.rule == CarveRule::kEveryPixel,
                                      camera.tiles.data(),
                                      camera.tiles.size(),
                                      camera.starts.data(),
                                      camera.one.window_cells.data(),
                                      camera.one.pixels.data(),
                                      camera.several.pixels.data(),
                                      camera.several.cells.data(),
                                      camera.two.cells.data(),
                                      camera.two.other_tiles.data(),
                                      camera.two.pixels.data(),
                                      camera.spread.cells.data(),
                                      camera.spread.pieces_first.data(),
                                      camera.spread.piece_tiles.data(),
                                      camera.spread.piece_pixels.data()};
  const std::uint8_t stamp = nextStamp();
  const fusion_steps::Blocking blocking{blocked_.data(), static_cast<std::uint32_t>(cell_count_),
                                        stamp, changed_tiles_.data()};
  (path_ == KernelPath::kSimd ? fusion_steps::blockCells : fusion_steps::blockCellsScalar)(
      lists, changed, blocking);
}

std::uint64_t FusionKernel::fuse(std::span<const std::uint8_t* const> changed,
                                 std::span<CellState> out,
                                 std::span<const std::uint32_t> generations) {
  if (changed.size() != cameras_.size() || out.size() != cell_count_ ||
      (!generations.empty() && generations.size() != cameras_.size())) {
    throw std::invalid_argument("fuse: one mask per camera and one state per cell");
  }
  // The map starts occupied where a live camera sees it (the paper), unseen elsewhere; each live
  // camera then frees the cells it sees and its changed pixels do not block.
  std::fill(free_.begin(), free_.end(), 0);
  std::fill(seen_.begin(), seen_.end(), 0);
  std::uint64_t fused = 0;
  for (std::size_t k = 0; k < cameras_.size(); ++k) {
    if (changed[k] == nullptr) continue;
    fusing_[k] = cameras_[k].table.load(std::memory_order_acquire);
    const CameraTable& camera = *fusing_[k];
    if (!generations.empty() && generations[k] != camera.generation) continue;
    fused |= std::uint64_t{1} << k;
    // A replaced table may have more tiles than any before (an allocation once, after a re-pose).
    if (changed_tiles_.size() < camera.tiles.size()) changed_tiles_.resize(camera.tiles.size());
    blockCells(camera, changed[k]);
    (path_ == KernelPath::kSimd ? fusion_steps::clearUnblocked
                                : fusion_steps::clearUnblockedScalar)(
        blocked_.data(), stamp_, camera.seen.data(), free_.data(), seen_.data(), camera.seen_begin,
        camera.seen_end);
  }
  auto* states = reinterpret_cast<std::uint8_t*>(out.data());
  (path_ == KernelPath::kSimd
       ? fusion_steps::writeCellStates
       : fusion_steps::writeCellStatesScalar)(seen_.data(), free_.data(), cell_count_, states);
  return fused;
}

std::string fusionSimdTarget() { return fusion_steps::simdTargetName(); }

}  // namespace occmap
