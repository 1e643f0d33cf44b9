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
// pixels keep the camera from clearing gets blocked_stamps[cell] = stamp; all other stores go to
// blocked_stamps[sink]. Per tile i of `tiles`, three lists: cells decided by one pixel of the tile,
// [one_first[i], one_first[i + 1]), as cell << 6 | bit; cells with several pixels in it, as
// (pixels, cell); and, in floor mode, cells with pixels in several tiles, listed under one of them
// with all their (tile, pixels) pieces. The one- and several-pixel lists have kListPadding
// readable entries past their end.
struct TileLists {
  bool column = false;  // column carving: any changed pixel blocks; else all must have changed
  const std::uint32_t* tiles = nullptr;
  std::size_t tile_count = 0;
  const std::uint32_t* one_first = nullptr;
  const std::uint32_t* one_cell_and_bit = nullptr;
  const std::uint32_t* several_first = nullptr;
  const std::uint64_t* several_pixels = nullptr;
  const std::uint32_t* several_cells = nullptr;
  const std::uint32_t* spread_first = nullptr;
  const std::uint32_t* spread_cells = nullptr;
  const std::uint32_t* spread_pieces_first = nullptr;
  const std::uint32_t* spread_piece_tiles = nullptr;
  const std::uint64_t* spread_piece_pixels = nullptr;
};
inline constexpr std::size_t kListPadding = 64;
struct Blocking {
  std::uint8_t* blocked_stamps;
  std::uint32_t sink;
  std::uint8_t stamp;
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
