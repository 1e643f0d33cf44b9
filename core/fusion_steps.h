#pragma once
// The fusion kernel's streaming steps (core/fusion_steps.cpp), each twice: SIMD through Google
// Highway, dispatched at run time to the best target this CPU has, and plain scalar C++, the
// yardstick the tests hold every SIMD target to. Internal to core/fusion_kernel.cpp, and exposed
// for its tests and benchmarks.

#include <cstddef>
#include <cstdint>
#include <string>

#include "core/image.h"

namespace occmap::fusion_steps {

// Eqs. 14-15 into changed-pixel tiles (layout: core/fusion_kernel.h, changedMaskBytes); the SIMD
// version needs 1 <= threshold <= 255. With `needed` (one flag per strip of 8 tiles, 64 pixels
// wide, ceil(width / 64) strips to a row of tiles), strips not needed are written unchanged without
// reading their pixels.
void markChangedTiles(ImageView live, ImageView background, int threshold,
                      const std::uint8_t* needed, std::uint8_t* tiles);
void markChangedTilesScalar(ImageView live, ImageView background, int threshold,
                            const std::uint8_t* needed, std::uint8_t* tiles);

// One camera's changed-pixel tiles against its tile lists (FusionKernel): every cell the changed
// pixels keep the camera from clearing gets blocked_stamps[cell] = stamp; other stores go to
// blocked_stamps[sink] or are masked off. Per tile i of `tiles`, four lists:
// - cells decided by one pixel of the tile, in windows of kWindowCells consecutive cells: window w
//   of the tile's starts at cell one_window_cells[w], and byte
//   one_pixels[w * kWindowCells + j] names cell one_window_cells[w] + j's pixel as
//   onePixelCode(bit), or is kNoCell for a cell not in the list;
// - cells with several pixels in it, as (pixels, cell);
// - in floor mode, cells with pixels in several tiles, listed under one of them: those with pixels
//   in exactly two tiles as (cell, other tile, pixels here, pixels there), the rest with all
//   their (tile, pixels) pieces.
// The several-pixel list has kListPadding readable entries past its end; blocked_stamps has
// kWindowCells bytes past any window's first cell.
// Where the i-th tile's lists start: list L is [starts[i].L, starts[i + 1].L). One record per
// tile, so that a visit to a tile begins with one cache line, not four.
struct TileStart {
  std::uint32_t one = 0;
  std::uint32_t several = 0;
  std::uint32_t two = 0;
  std::uint32_t spread = 0;
};
struct TileLists {
  bool column = false;  // column carving: any changed pixel blocks; else all must have changed
  const std::uint32_t* tiles = nullptr;
  std::size_t tile_count = 0;
  const TileStart* starts = nullptr;  // tile_count + 1
  const std::uint32_t* one_window_cells = nullptr;
  const std::uint8_t* one_pixels = nullptr;
  const std::uint64_t* several_pixels = nullptr;
  const std::uint32_t* several_cells = nullptr;
  const std::uint32_t* two_cells = nullptr;
  const std::uint32_t* two_other_tiles = nullptr;
  const std::uint64_t* two_pixels = nullptr;  // per entry: pixels in this tile, in the other
  const std::uint32_t* spread_cells = nullptr;
  const std::uint32_t* spread_pieces_first = nullptr;
  const std::uint32_t* spread_piece_tiles = nullptr;
  const std::uint64_t* spread_piece_pixels = nullptr;
};
// A window of the one-pixel list: 16 consecutive cells, the width of the narrowest vector (SSE4,
// NEON), so that every target reads the same tables. One masked store of 16 stamps replaces up
// to 16 byte stores: far from a camera several cells share each pixel, and a tile's one-pixel
// cells come in short rows of the map (some 6 to a window in the benchmarks' scenes).
inline constexpr std::size_t kWindowCells = 16;
// A pixel's tile bit b (row b / 8, column b % 8) as a window byte: the row in the low nibble and
// the column in the high one, each a byte-shuffle index. kNoCell's column, 15, looks up no bit.
constexpr std::uint8_t onePixelCode(unsigned bit) {
  return static_cast<std::uint8_t>((bit % 8) << 4 | bit / 8);
}
inline constexpr std::uint8_t kNoCell = 0xF0;
inline constexpr std::size_t kListPadding = 64;
struct Blocking {
  std::uint8_t* blocked_stamps;
  std::uint32_t sink;
  std::uint8_t stamp;
  // Scratch of lists.tile_count entries: the positions in `tiles` of the tiles with a changed
  // pixel, gathered before the visit so that the visit neither branches on each tile nor waits for
  // the next one's lists.
  std::uint32_t* changed_tiles;
};
void blockCells(const TileLists& lists, const std::uint8_t* changed, const Blocking& blocking);
void blockCellsScalar(const TileLists& lists, const std::uint8_t* changed,
                      const Blocking& blocking);

// One camera's part of the map: for words j in [begin, end) of the cell bitsets,
// free[j] |= seen[j] & ~blocked and seen_by_any[j] |= seen[j], where cell c is blocked when
// blocked_stamps[c] == stamp. blocked_stamps holds at least 64 * end bytes.
void clearUnblocked(const std::uint8_t* blocked_stamps, std::uint8_t stamp,
                    const std::uint64_t* seen, std::uint64_t* free, std::uint64_t* seen_by_any,
                    std::size_t begin, std::size_t end);
void clearUnblockedScalar(const std::uint8_t* blocked_stamps, std::uint8_t stamp,
                          const std::uint64_t* seen, std::uint64_t* free,
                          std::uint64_t* seen_by_any, std::size_t begin, std::size_t end);

// The three states from the cell bitsets (a cell free is also seen): FREE 0, OCCUPIED 1 (seen,
// not free), UNSEEN 2, i.e. 2 - seen - free, into `cells` bytes.
void writeCellStates(const std::uint64_t* seen, const std::uint64_t* free, std::size_t cells,
                     std::uint8_t* out);
void writeCellStatesScalar(const std::uint64_t* seen, const std::uint64_t* free, std::size_t cells,
                           std::uint8_t* out);

// The Highway target the SIMD versions dispatch to now ("AVX3", "AVX2", "NEON", "EMU128", ...).
std::string simdTargetName();

}  // namespace occmap::fusion_steps
