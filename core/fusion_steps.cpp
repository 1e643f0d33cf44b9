// The fusion kernel's streaming steps, compiled once per SIMD target by Highway's foreach_target
// (this file includes itself once per target) and dispatched at run time; the scalar versions at
// the end are the yardstick.
#include "core/fusion_steps.h"

#include <algorithm>
#include <bit>
#include <cstring>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "core/fusion_steps.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
// foreach_target.h must come first.
#include "hwy/cache_control.h"
#include "hwy/highway.h"

static_assert(std::endian::native == std::endian::little,
              "the tile and cell bit layouts are defined as little-endian words");

HWY_BEFORE_NAMESPACE();
namespace occmap::fusion_steps::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// At most 64 byte lanes, so that a whole number of vectors makes one 64-bit word of bits.
using ByteTag = hn::CappedTag<std::uint8_t, 64>;

// Whether this target's byte vectors split a 64-bit word into whole bytes of mask bits.
HWY_INLINE bool wordsFit(ByteTag d) {
  const std::size_t n = hn::Lanes(d);
  return n >= 8 && 64 % n == 0;
}

// One bit per pixel for 64 pixels of a row into bytes[0..7], 1 where |a - b| > limit (eq. 15
// with limit = threshold - 1); |a - b| is the OR of the two saturated differences, one of which is
// 0.
HWY_INLINE void changedBits(ByteTag d, const std::uint8_t* HWY_RESTRICT a,
                            const std::uint8_t* HWY_RESTRICT b, hn::Vec<ByteTag> limit,
                            std::uint8_t* HWY_RESTRICT bytes) {
  const std::size_t n = hn::Lanes(d);
  for (std::size_t i = 0; i < 64; i += n) {
    const auto va = hn::LoadU(d, a + i);
    const auto vb = hn::LoadU(d, b + i);
    const auto difference = hn::Or(hn::SaturatedSub(va, vb), hn::SaturatedSub(vb, va));
    hn::StoreMaskBits(d, hn::Gt(difference, limit), bytes + i / 8);
  }
}

// Eight rows of bits (bytes 8y..8y+7: row y, byte t covering tile t) turned into eight tile words
// (bytes 8t..8t+7: tile t, byte y = row y): an 8 x 8 byte transpose, by interleaving bytes, then
// pairs, then quads of rows, as one would with SSE2's unpack instructions.
HWY_INLINE void transposeBytes(const std::uint8_t* HWY_RESTRICT rows,
                               std::uint8_t* HWY_RESTRICT out) {
#if HWY_TARGET == HWY_SCALAR
  for (int t = 0; t < 8; ++t) {
    for (int y = 0; y < 8; ++y) out[t * 8 + y] = rows[y * 8 + t];
  }
#else
  const hn::Full128<std::uint8_t> d8;
  const hn::Repartition<std::uint16_t, decltype(d8)> d16;
  const hn::Repartition<std::uint32_t, decltype(d8)> d32;
  // Each row by itself: the rows were just stored 8 bytes at a time, and a 16-byte load of two
  // would wait for both stores to reach the cache (no store forwarding across two stores).
  const hn::Full64<std::uint8_t> d8_half;
  auto pairRows = [&](const std::uint8_t* two_rows) {  // r0 b0, r1 b0, r0 b1, r1 b1, ...
    const auto first = hn::ZeroExtendVector(d8, hn::LoadU(d8_half, two_rows));
    const auto second = hn::ZeroExtendVector(d8, hn::LoadU(d8_half, two_rows + 8));
    return hn::BitCast(d16, hn::InterleaveLower(d8, first, second));
  };
  const auto rows01 = pairRows(rows), rows23 = pairRows(rows + 16);
  const auto rows45 = pairRows(rows + 32), rows67 = pairRows(rows + 48);
  const auto low03 = hn::BitCast(d32, hn::InterleaveLower(d16, rows01, rows23));   // tiles 0-3
  const auto high03 = hn::BitCast(d32, hn::InterleaveUpper(d16, rows01, rows23));  // tiles 4-7
  const auto low47 = hn::BitCast(d32, hn::InterleaveLower(d16, rows45, rows67));
  const auto high47 = hn::BitCast(d32, hn::InterleaveUpper(d16, rows45, rows67));
  hn::StoreU(hn::BitCast(d8, hn::InterleaveLower(d32, low03, low47)), d8, out);
  hn::StoreU(hn::BitCast(d8, hn::InterleaveUpper(d32, low03, low47)), d8, out + 16);
  hn::StoreU(hn::BitCast(d8, hn::InterleaveLower(d32, high03, high47)), d8, out + 32);
  hn::StoreU(hn::BitCast(d8, hn::InterleaveUpper(d32, high03, high47)), d8, out + 48);
#endif
}

void markChangedTilesVector(ImageView live, ImageView background, int threshold,
                            const std::uint8_t* HWY_RESTRICT needed,
                            std::uint8_t* HWY_RESTRICT tiles) {
  const ByteTag d;
  if (!wordsFit(d)) {
    markChangedTilesScalar(live, background, threshold, needed, tiles);
    return;
  }
  const auto limit = hn::Set(d, static_cast<std::uint8_t>(threshold - 1));
  const int width = live.width;
  const int tiles_across = (width + 7) / 8;
  const int strips = width / 64;  // 64 pixels = 8 tiles per vector step; the rest pixel by pixel
  const int strips_across = (width + 63) / 64;
  for (int tile_row = 0; tile_row * 8 < live.height; ++tile_row) {
    const int rows = std::min(8, live.height - tile_row * 8);
    std::uint8_t* out = tiles + static_cast<std::ptrdiff_t>(tile_row) * tiles_across * 8;
    const std::uint8_t* needed_here =
        needed == nullptr ? nullptr
                          : needed + static_cast<std::ptrdiff_t>(tile_row) * strips_across;
    // The live image comes from memory (a new frame each time): its rows of the next row of tiles,
    // and the background's, are asked for now, so that they arrive while this one is compared.
    // The hardware's own prefetch, which follows each row, starts too late for rows of 64-pixel
    // strips (the benchmark's cold difference: 105 us without, 87 us with; asking strip by strip
    // instead of a row of tiles at once was slower).
    const int ahead_row = tile_row + 1;
    if (ahead_row * 8 < live.height) {
      const std::uint8_t* needed_ahead =
          needed == nullptr ? nullptr
                            : needed + static_cast<std::ptrdiff_t>(ahead_row) * strips_across;
      const int ahead_rows = std::min(8, live.height - ahead_row * 8);
      for (int strip = 0; strip < strips_across; ++strip) {
        if (needed_ahead != nullptr && needed_ahead[strip] == 0) continue;
        for (int y = 0; y < ahead_rows; ++y) {
          hwy::Prefetch(live.row(ahead_row * 8 + y) + strip * 64);
          hwy::Prefetch(background.row(ahead_row * 8 + y) + strip * 64);
        }
      }
    }
    for (int strip = 0; strip < strips; ++strip) {
      if (needed_here != nullptr && needed_here[strip] == 0) {
        std::memset(out + strip * 64, 0, 64);
        continue;
      }
      HWY_ALIGN std::uint8_t bits[64] = {};  // rows past the image's bottom stay unchanged
      for (int y = 0; y < rows; ++y) {
        const int v = tile_row * 8 + y;
        changedBits(d, live.row(v) + strip * 64, background.row(v) + strip * 64, limit,
                    bits + y * 8);
      }
      transposeBytes(bits, out + strip * 64);
    }
    // A width that is a multiple of 64 has no tail (and no entry for one in `needed`).
    const bool tail_needed =
        strips < strips_across && (needed_here == nullptr || needed_here[strips] != 0);
    for (int tile = strips * 8; tile < tiles_across; ++tile) {
      std::uint64_t word = 0;
      if (!tail_needed) {
        std::memcpy(out + tile * 8, &word, sizeof word);
        continue;
      }
      for (int y = 0; y < rows; ++y) {
        const std::uint8_t* a = live.row(tile_row * 8 + y);
        const std::uint8_t* b = background.row(tile_row * 8 + y);
        for (int u = tile * 8; u < std::min(width, tile * 8 + 8); ++u) {
          const int difference = a[u] > b[u] ? a[u] - b[u] : b[u] - a[u];
          if (difference >= threshold) word |= std::uint64_t{1} << (y * 8 + (u - tile * 8));
        }
      }
      std::memcpy(out + tile * 8, &word, sizeof word);
    }
  }
}

// The tile word of the changed mask.
HWY_INLINE std::uint64_t tileWord(const std::uint8_t* changed, std::uint32_t tile) {
  std::uint64_t word;
  std::memcpy(&word, changed + static_cast<std::size_t>(tile) * 8, sizeof word);
  return word;
}

// Whether all the pixels of a spread cell (floor mode) changed.
HWY_INLINE bool spreadBlocked(const TileLists& lists, const std::uint8_t* HWY_RESTRICT changed,
                              std::uint32_t e) {
  for (std::uint32_t p = lists.spread_pieces_first[e]; p < lists.spread_pieces_first[e + 1]; ++p) {
    const std::uint64_t pixels = lists.spread_piece_pixels[p];
    if ((tileWord(changed, lists.spread_piece_tiles[p]) & pixels) != pixels) return false;
  }
  return true;
}

// The stamps of a window's blocked cells in one store. AVX-512 stores bytes under a mask; on the
// narrower x86 targets Highway's BlendedStore does it lane by lane with a branch each, which was
// 70 % of the floor fusion's time on AVX2 (three times its AVX-512 time on the same CPU). There the
// window is read, blended and written back whole: its bytes are this fusion's own, on one thread,
// and readable (blocked_stamps has kWindowCells bytes past any window's first cell).
template <class D, class V, class M>
HWY_INLINE void storeStamps(D d8, V stamps, M blocked_cells, std::uint8_t* HWY_RESTRICT window) {
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3
  hn::BlendedStore(stamps, blocked_cells, d8, window);
#else
  hn::StoreU(hn::IfThenElse(blocked_cells, stamps, hn::LoadU(d8, window)), d8, window);
#endif
}

// One-pixel windows end in one masked store each. The several-pixel tests run in vectors and leave,
// per entry, the index to stamp (the cell when its changed pixels block it, else the sink); the
// byte stores that follow are scalar, there being no byte scatter.
void blockCellsVector(const TileLists& lists_given, const std::uint8_t* HWY_RESTRICT changed,
                      const Blocking& blocking) {
  // A copy the byte stores below cannot alias, so its pointers stay in registers.
  const TileLists lists = lists_given;
#if HWY_TARGET == HWY_SCALAR
  blockCellsScalar(lists, changed, blocking);  // no 16-byte vectors
#else
  const hn::ScalableTag<std::uint64_t> d64;
  const hn::Rebind<std::uint32_t, decltype(d64)> d32_of_64;
  const hn::FixedTag<std::uint8_t, kWindowCells> d8;
  const hn::Repartition<std::uint64_t, decltype(d8)> d64_128;
  const std::size_t n64 = hn::Lanes(d64);
  if (hn::Lanes(d8) != kWindowCells || n64 > kListPadding) {
    blockCellsScalar(lists, changed, blocking);
    return;
  }
  HWY_ALIGN std::uint64_t targets64[hn::MaxLanes(d64)];
  std::uint8_t* HWY_RESTRICT blocked = blocking.blocked_stamps;
  const std::uint8_t stamp = blocking.stamp;
  const auto stamps = hn::Set(d8, stamp);
  const auto low_nibble = hn::Set(d8, 0x0F);
  const auto zero8 = hn::Zero(d8);
  // A column's bit in a row byte, by the column's index; 8-15 (kNoCell's 15) are no bit.
  HWY_ALIGN static constexpr std::uint8_t kColumnBits[kWindowCells] = {1, 2, 4, 8, 16, 32, 64, 128};
  const auto column_bits = hn::Load(d8, kColumnBits);
  const auto sink64 = hn::Set(d64, blocking.sink);
  const auto zero64 = hn::Zero(d64);
  // The tiles with a changed pixel (some 15 %), gathered without a branch per tile; then each is
  // visited while, in floor mode, the lists of the one two visits ahead are fetched. (Floor lists
  // are short, a few cache lines a tile, and begin where the hardware cannot guess: 5 % faster in
  // the benchmark's floor fusion. Column-mode lists are long, and there the same prefetch made
  // the large fusion 15-20 % slower.)
  std::uint32_t* HWY_RESTRICT visit = blocking.changed_tiles;
  std::size_t visits = 0;
  for (std::size_t i = 0; i < lists.tile_count; ++i) {
    visit[visits] = static_cast<std::uint32_t>(i);
    visits += tileWord(changed, lists.tiles[i]) != 0 ? 1 : 0;
  }
  constexpr std::size_t kAheadTiles = 2;
  for (std::size_t v = 0; v < visits; ++v) {
    if (!lists.column && v + kAheadTiles < visits) {
      const std::uint32_t ahead = visit[v + kAheadTiles];
      const TileStart& start = lists.starts[ahead];
      hwy::Prefetch(lists.one_pixels + std::size_t{start.one} * kWindowCells);
      hwy::Prefetch(lists.several_pixels + start.several);
      hwy::Prefetch(lists.several_cells + start.several);
      hwy::Prefetch(lists.one_window_cells + start.one);
      hwy::Prefetch(lists.two_pixels + std::size_t{start.two} * 2);
    }
    const std::size_t i = visit[v];
    const std::uint64_t word = tileWord(changed, lists.tiles[i]);
    // One pixel decides: blocked when it changed, in either mode. Per window, each cell's row
    // byte of the tile word and its column's bit are looked up by byte shuffles, and the stamps
    // of the cells whose pixel changed go out in one masked store.
    const auto tile_bytes = hn::BitCast(d8, hn::Set(d64_128, word));
    for (std::uint32_t w = lists.starts[i].one, end = lists.starts[i + 1].one; w < end; ++w) {
      const auto code = hn::LoadU(d8, lists.one_pixels + std::size_t{w} * kWindowCells);
      const auto row = hn::TableLookupBytes(tile_bytes, hn::And(code, low_nibble));
      const auto column_bit = hn::TableLookupBytes(column_bits, hn::ShiftRight<4>(code));
      const auto changed_pixel = hn::Ne(hn::And(row, column_bit), zero8);
      storeStamps(d8, stamps, changed_pixel, blocked + lists.one_window_cells[w]);
    }
    // Several pixels: column carving blocks on any changed one, floor carving only on all.
    const auto tile = hn::Set(d64, word);
    for (std::uint32_t e = lists.starts[i].several, end = lists.starts[i + 1].several; e < end;
         e += static_cast<std::uint32_t>(n64)) {
      const auto pixels = hn::LoadU(d64, lists.several_pixels + e);
      const auto common = hn::And(tile, pixels);
      const auto blocks = lists.column ? hn::Ne(common, zero64) : hn::Eq(common, pixels);
      const std::size_t count = std::min<std::size_t>(n64, end - e);
      const auto cells = hn::PromoteTo(d64, hn::LoadU(d32_of_64, lists.several_cells + e));
      hn::Store(hn::IfThenElse(hn::And(blocks, hn::FirstN(d64, count)), cells, sink64), d64,
                targets64);
      for (std::size_t j = 0; j < n64; ++j) blocked[targets64[j]] = stamp;
    }
    // Floor-mode cells with pixels in other tiles too: blocked when every piece fully changed.
    // Those of two tiles without a branch (the answer is a coin toss to a predictor).
    for (std::uint32_t e = lists.starts[i].two, end = lists.starts[i + 1].two; e < end; ++e) {
      const std::uint64_t here = lists.two_pixels[std::size_t{e} * 2];
      const std::uint64_t there = lists.two_pixels[std::size_t{e} * 2 + 1];
      const bool all = ((word & here) == here) &
                       ((tileWord(changed, lists.two_other_tiles[e]) & there) == there);
      blocked[all ? lists.two_cells[e] : blocking.sink] = stamp;
    }
    for (std::uint32_t e = lists.starts[i].spread, end = lists.starts[i + 1].spread; e < end; ++e) {
      if (spreadBlocked(lists, changed, e)) blocked[lists.spread_cells[e]] = stamp;
    }
  }
#endif
}

void clearUnblockedVector(const std::uint8_t* HWY_RESTRICT blocked_stamps, std::uint8_t stamp,
                          const std::uint64_t* HWY_RESTRICT seen, std::uint64_t* HWY_RESTRICT free,
                          std::uint64_t* HWY_RESTRICT seen_by_any, std::size_t begin,
                          std::size_t end) {
  const ByteTag d;
  if (!wordsFit(d)) {
    clearUnblockedScalar(blocked_stamps, stamp, seen, free, seen_by_any, begin, end);
    return;
  }
  const std::size_t n = hn::Lanes(d);
  const auto wanted = hn::Set(d, stamp);
  for (std::size_t word = begin; word < end; ++word) {
    std::uint8_t bytes[8] = {};
    for (std::size_t i = 0; i < 64; i += n) {
      const auto stamps = hn::LoadU(d, blocked_stamps + word * 64 + i);
      hn::StoreMaskBits(d, hn::Eq(stamps, wanted), bytes + i / 8);
    }
    std::uint64_t blocked;
    std::memcpy(&blocked, bytes, sizeof blocked);
    free[word] |= seen[word] & ~blocked;
    seen_by_any[word] |= seen[word];
  }
}

void writeCellStatesVector(const std::uint64_t* HWY_RESTRICT seen,
                           const std::uint64_t* HWY_RESTRICT free, std::size_t cells,
                           std::uint8_t* HWY_RESTRICT out) {
  const ByteTag d;
  if (!wordsFit(d)) {
    writeCellStatesScalar(seen, free, cells, out);
    return;
  }
  const std::size_t n = hn::Lanes(d);
  const auto one = hn::Set(d, 1);
  const auto two = hn::Set(d, 2);
  const std::size_t words = cells / 64;
  for (std::size_t word = 0; word < words; ++word) {
    std::uint8_t seen_bits[8], free_bits[8];
    std::memcpy(seen_bits, seen + word, 8);
    std::memcpy(free_bits, free + word, 8);
    for (std::size_t i = 0; i < 64; i += n) {
      const auto is_seen = hn::LoadMaskBits(d, seen_bits + i / 8);
      const auto is_free = hn::LoadMaskBits(d, free_bits + i / 8);
      const auto state =
          hn::Sub(hn::Sub(two, hn::IfThenElseZero(is_seen, one)), hn::IfThenElseZero(is_free, one));
      hn::StoreU(state, d, out + word * 64 + i);
    }
  }
  if (words * 64 < cells) {
    writeCellStatesScalar(seen + words, free + words, cells - words * 64, out + words * 64);
  }
}

std::int64_t compiledTarget() { return HWY_TARGET; }

}  // namespace occmap::fusion_steps::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace occmap::fusion_steps {

HWY_EXPORT(markChangedTilesVector);
HWY_EXPORT(blockCellsVector);
HWY_EXPORT(clearUnblockedVector);
HWY_EXPORT(writeCellStatesVector);
HWY_EXPORT(compiledTarget);

void markChangedTiles(ImageView live, ImageView background, int threshold,
                      const std::uint8_t* needed, std::uint8_t* tiles) {
  HWY_DYNAMIC_DISPATCH(markChangedTilesVector)(live, background, threshold, needed, tiles);
}

void blockCells(const TileLists& lists, const std::uint8_t* changed, const Blocking& blocking) {
  HWY_DYNAMIC_DISPATCH(blockCellsVector)(lists, changed, blocking);
}

void clearUnblocked(const std::uint8_t* blocked_stamps, std::uint8_t stamp,
                    const std::uint64_t* seen, std::uint64_t* free, std::uint64_t* seen_by_any,
                    std::size_t begin, std::size_t end) {
  HWY_DYNAMIC_DISPATCH(clearUnblockedVector)
  (blocked_stamps, stamp, seen, free, seen_by_any, begin, end);
}

void writeCellStates(const std::uint64_t* seen, const std::uint64_t* free, std::size_t cells,
                     std::uint8_t* out) {
  HWY_DYNAMIC_DISPATCH(writeCellStatesVector)(seen, free, cells, out);
}

std::string simdTargetName() { return hwy::TargetName(HWY_DYNAMIC_DISPATCH(compiledTarget)()); }

void markChangedTilesScalar(ImageView live, ImageView background, int threshold,
                            const std::uint8_t* needed, std::uint8_t* tiles) {
  const int tiles_across = (live.width + 7) / 8;
  const int tiles_down = (live.height + 7) / 8;
  std::memset(tiles, 0,
              static_cast<std::size_t>(tiles_across) * static_cast<std::size_t>(tiles_down) * 8);
  for (int v = 0; v < live.height; ++v) {
    const std::uint8_t* a = live.row(v);
    const std::uint8_t* b = background.row(v);
    for (int u = 0; u < live.width; ++u) {
      const int difference = a[u] > b[u] ? a[u] - b[u] : b[u] - a[u];
      if (difference < threshold) continue;
      const std::size_t word =
          static_cast<std::size_t>(v / 8) * static_cast<std::size_t>(tiles_across) +
          static_cast<std::size_t>(u / 8);
      tiles[word * 8 + static_cast<std::size_t>(v % 8)] |= static_cast<std::uint8_t>(1u << (u % 8));
    }
  }
  if (needed == nullptr) return;
  // Strips not needed read as unchanged, whatever their pixels.
  const int strips_across = (live.width + 63) / 64;
  for (int tile_row = 0; tile_row < tiles_down; ++tile_row) {
    for (int tile = 0; tile < tiles_across; ++tile) {
      if (needed[tile_row * strips_across + tile / 8] != 0) continue;
      std::memset(tiles + static_cast<std::size_t>(tile_row * tiles_across + tile) * 8, 0, 8);
    }
  }
}

void blockCellsScalar(const TileLists& lists, const std::uint8_t* changed,
                      const Blocking& blocking) {
  std::uint8_t* blocked = blocking.blocked_stamps;
  for (std::size_t i = 0; i < lists.tile_count; ++i) {
    std::uint64_t word;
    std::memcpy(&word, changed + static_cast<std::size_t>(lists.tiles[i]) * 8, sizeof word);
    if (word == 0) continue;
    for (std::uint32_t w = lists.starts[i].one; w < lists.starts[i + 1].one; ++w) {
      for (std::size_t j = 0; j < kWindowCells; ++j) {
        const std::uint8_t code = lists.one_pixels[std::size_t{w} * kWindowCells + j];
        if (code == kNoCell) continue;
        const unsigned bit = (code & 15u) * 8 + (code >> 4);
        if ((word >> bit & 1) != 0) blocked[lists.one_window_cells[w] + j] = blocking.stamp;
      }
    }
    for (std::uint32_t e = lists.starts[i].several; e < lists.starts[i + 1].several; ++e) {
      const std::uint64_t pixels = lists.several_pixels[e];
      const bool blocks = lists.column ? (word & pixels) != 0 : (word & pixels) == pixels;
      if (blocks) blocked[lists.several_cells[e]] = blocking.stamp;
    }
    for (std::uint32_t e = lists.starts[i].two; e < lists.starts[i + 1].two; ++e) {
      std::uint64_t there;
      std::memcpy(&there, changed + static_cast<std::size_t>(lists.two_other_tiles[e]) * 8,
                  sizeof there);
      const std::uint64_t* pixels = lists.two_pixels + std::size_t{e} * 2;
      if ((word & pixels[0]) == pixels[0] && (there & pixels[1]) == pixels[1]) {
        blocked[lists.two_cells[e]] = blocking.stamp;
      }
    }
    for (std::uint32_t e = lists.starts[i].spread; e < lists.starts[i + 1].spread; ++e) {
      bool all = true;
      for (std::uint32_t p = lists.spread_pieces_first[e]; p < lists.spread_pieces_first[e + 1];
           ++p) {
        std::uint64_t piece_word;
        std::memcpy(&piece_word,
                    changed + static_cast<std::size_t>(lists.spread_piece_tiles[p]) * 8,
                    sizeof piece_word);
        all = all && (piece_word & lists.spread_piece_pixels[p]) == lists.spread_piece_pixels[p];
      }
      if (all) blocked[lists.spread_cells[e]] = blocking.stamp;
    }
  }
}

void clearUnblockedScalar(const std::uint8_t* blocked_stamps, std::uint8_t stamp,
                          const std::uint64_t* seen, std::uint64_t* free,
                          std::uint64_t* seen_by_any, std::size_t begin, std::size_t end) {
  for (std::size_t word = begin; word < end; ++word) {
    seen_by_any[word] |= seen[word];
    for (std::size_t bit = 0; bit < 64; ++bit) {
      const std::uint64_t one = std::uint64_t{1} << bit;
      if ((seen[word] & one) != 0 && blocked_stamps[word * 64 + bit] != stamp) free[word] |= one;
    }
  }
}

void writeCellStatesScalar(const std::uint64_t* seen, const std::uint64_t* free, std::size_t cells,
                           std::uint8_t* out) {
  for (std::size_t cell = 0; cell < cells; ++cell) {
    const std::uint64_t one = std::uint64_t{1} << (cell % 64);
    const bool is_free = (free[cell / 64] & one) != 0;
    const bool is_seen = (seen[cell / 64] & one) != 0;
    out[cell] = is_free ? 0 : (is_seen ? 1 : 2);
  }
}

}  // namespace occmap::fusion_steps
#endif  // HWY_ONCE
