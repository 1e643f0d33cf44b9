#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/carve_table.h"
#include "core/fusion_steps.h"
#include "core/image.h"
#include "core/map_geometry.h"

namespace occmap {

// Which code runs the fusion's vector steps: SIMD through Google Highway, dispatched at run time to
// the best target of this CPU (AVX2, AVX-512, NEON, ...), or plain scalar C++ that the tests hold
// the SIMD code to. Both give the same bits.
enum class KernelPath : std::uint8_t { kSimd, kScalar };

// A camera frame's changed pixels (the paper's image-space occupancy map O_I, eq. 15) as bits, in
// tiles of 8 x 8 pixels: 64-bit word (v / 8) * ceil(width / 8) + u / 8 holds pixel (u, v) at bit
// (v % 8) * 8 + u % 8, 1 = changed, little-endian in memory. Tiles, because the pixels that decide
// one cell are a small blob of the image (floor) or a short, nearly vertical line (column): they
// fall into one to a few tiles, and one word answers for all of a cell's pixels in a tile at once.
// The buffer is changedMaskBytes(width, height) bytes.
std::size_t changedMaskBytes(int width, int height);
// The mask's tiles in a row of them, and its rows of tiles.
inline std::size_t tilesAcross(int width) { return (static_cast<std::size_t>(width) + 7) / 8; }
inline std::size_t tilesDown(int height) { return (static_cast<std::size_t>(height) + 7) / 8; }

// The paper's difference and threshold (eqs. 14-15) for one camera frame: a pixel is changed (no
// clear ray) when |live - background| >= threshold. This is the capture threads' share of the
// work, done while the pixels are hot; it writes all changedMaskBytes(width, height) bytes.
void markChangedPixels(ImageView live, ImageView background, int threshold, std::uint8_t* changed,
                       KernelPath path = KernelPath::kSimd);

// The fusion as the pipeline runs it, equal cell for cell to fuseReference (tests hold it to that).
// Built once from the carve tables; fuse() allocates nothing.
//
// The tables are turned around, from cells to the 8 x 8 pixel tiles of the changed mask: each tile
// lists the cells with pixels in it and, per cell, which of its 64 pixels they are. A camera clears
// every cell it sees except those its changed pixels block: in column mode (every pixel must be
// unchanged) a cell is blocked when any of its pixels changed, in floor mode (any unchanged pixel
// clears) when all of them did. Either way only tiles with a changed pixel are visited (some 15 %
// of them in the benchmarks' scenes), and nothing is scattered into the map itself: per camera,
// blocked cells get a stamp, and one pass over the stamps turns them into the camera's cleared
// bits; a last pass writes the three states.
class FusionKernel {
  struct CameraTable;  // below, with the rest of what is private

 public:
  static constexpr std::size_t kMaxCameras = 64;

  // Throws std::invalid_argument for more than kMaxCameras tables or tables of different maps.
  explicit FusionKernel(std::span<const CarveTable> tables, KernelPath path = KernelPath::kSimd);

  // markChangedPixels for camera k, reading only the pixels that decide some cell: the 64-pixel
  // strips of each row of tiles that no table entry names (a third to a half of an image: walls,
  // shelves, ceiling) are written unchanged without being read. Safe to call from one thread per
  // camera while another runs fuse(). Throws std::invalid_argument when an image's size is not the
  // camera's table's.
  // Returns the generation of the camera's table it used (see replaceCamera).
  std::uint32_t markChangedPixels(std::size_t camera, ImageView live, ImageView background,
                                  int threshold, std::uint8_t* changed) const;

  // changed[k]: camera k's changed-pixel mask (markChangedPixels), or nullptr when camera k is not
  // in this frame set (down or late): then its cells count only if another camera sees them.
  // `out` has the map's cell count. With `generations` (one per camera: what markChangedPixels
  // returned for each mask), a mask marked under another table than the one fuse() finds is left
  // out like a missing one. Returns the cameras whose masks counted, bit k for camera k.
  std::uint64_t fuse(std::span<const std::uint8_t* const> changed, std::span<CellState> out,
                     std::span<const std::uint32_t> generations = {});

  std::size_t cameraCount() const { return cameras_.size(); }

  // A carve table turned around for replaceCamera: the costly part (tens of milliseconds for large
  // tables), which any thread may do.
  class Replacement {
   public:
    Replacement() = default;

   private:
    friend class FusionKernel;
    std::shared_ptr<CameraTable> table_;
  };
  static Replacement prepareReplacement(const CarveTable& table);
  // Camera k's table replaced by one for the same map and image size (a camera re-posed after a
  // knock, core/repose.h); its generation goes up by one. Safe while another thread runs fuse()
  // and others mark other cameras' pixels; camera k's own markChangedPixels must be called by the
  // calling thread (the camera's capture thread) or not at all meanwhile. Throws
  // std::invalid_argument for a table of another map or size.
  void replaceCamera(std::size_t camera, Replacement replacement);
  void replaceCamera(std::size_t camera, const CarveTable& table) {
    replaceCamera(camera, prepareReplacement(table));
  }
  std::uint32_t generation(std::size_t camera) const;
  // Bytes of the turned-around tables (what fuse() may read besides the masks).
  std::size_t tableBytes() const;

 private:
  // A tile's cells come in four lists, so that the common case costs least: cells decided by one
  // pixel of the tile (a bit position), cells with several pixels in it (a 64-bit mask), and, in
  // floor mode only, cells with pixels in other tiles too, listed once, under their first tile:
  // those with pixels in exactly two tiles (most of them) with both masks, the rest ("spread")
  // with all their tiles and pixels. (Column mode needs neither: there any one tile can block the
  // cell alone.) Each list in cell order; `starts` says where the i-th tile of `tiles` has its
  // entries in each.
  struct OnePixel {  // in windows of consecutive cells (fusion_steps::TileLists)
    std::vector<std::uint32_t> window_cells;  // each window's first cell
    std::vector<std::uint8_t> pixels;         // kWindowCells codes per window
  };
  struct SeveralPixels {
    std::vector<std::uint64_t> pixels;  // the cell's pixels in the tile, as tile bits
    std::vector<std::uint32_t> cells;
  };
  struct TwoTiles {  // floor-mode cells with pixels in exactly two tiles, the common spread case
    std::vector<std::uint32_t> cells;
    std::vector<std::uint32_t> other_tiles;
    std::vector<std::uint64_t> pixels;  // per entry two: in this tile, in the other
  };
  struct SpreadCells {
    std::vector<std::uint32_t> cells;
    std::vector<std::uint32_t> pieces_first;  // per entry + 1: its pieces
    std::vector<std::uint32_t> piece_tiles;
    std::vector<std::uint64_t> piece_pixels;
  };
  struct CameraTable {
    CarveRule rule = CarveRule::kAnyPixel;
    int image_width = 0;
    int image_height = 0;
    // Per row of tiles, per 64-pixel strip of it: whether some tile of it decides a cell.
    std::vector<std::uint8_t> needed_strips;
    std::vector<std::uint32_t> tiles;  // tiles with pixels that decide some cell, ascending
    std::vector<fusion_steps::TileStart> starts;  // per tile of `tiles`, + 1
    OnePixel one;
    SeveralPixels several;
    TwoTiles two;
    SpreadCells spread;
    std::vector<std::uint64_t> seen;  // bit per cell: the camera sees it
    std::size_t seen_begin = 0;       // words of `seen` with a bit set: [seen_begin, seen_end)
    std::size_t seen_end = 0;
    std::uint32_t generation = 0;  // replaceCamera's count
    std::size_t cells = 0;         // of its map
  };
  // Each camera's table, replaced whole (replaceCamera) while other threads may read the old one:
  // they hold it as long as they use it.
  struct CameraSlot {
    std::atomic<std::shared_ptr<const CameraTable>> table;
  };
  static CameraTable turnAround(const CarveTable& table);
  void blockCells(const CameraTable& camera, const std::uint8_t* changed);
  std::uint8_t nextStamp();

  KernelPath path_;
  std::size_t cell_count_ = 0;
  std::vector<CameraSlot> cameras_;  // sized once: the slots never move
  // fuse()'s own hold on each table it fuses (fusion thread only; no allocation per map).
  std::vector<std::shared_ptr<const CameraTable>> fusing_;
  std::vector<std::uint8_t> blocked_;  // per cell (+ a sink): stamp of the camera that blocked it
  std::uint8_t stamp_ = 0;
  std::vector<std::uint32_t> changed_tiles_;  // blockCells' scratch: the most tiles of any camera
                                              // (grown by fuse() after a replaceCamera)
  std::vector<std::uint64_t> free_;           // bit per cell, this frame set
  std::vector<std::uint64_t> seen_;           // bit per cell: some live camera sees it
};

// The name of the Highway target the SIMD path dispatches to on this CPU ("AVX3", "AVX2", ...).
std::string fusionSimdTarget();

}  // namespace occmap
