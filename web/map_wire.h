#pragma once
// One map as a binary WebSocket message to the browser (docs/web.md, "Map frames"): a 64-byte
// header and the cells packed two bits each, four to a byte. zstd is not in browsers; two bits a
// cell are a quarter of map_frame_t's raw cells, need no decompressor in JavaScript and cost the
// same whatever the map shows (a 512 x 512 map: 65 600 bytes). Encoded once per map and shared by
// every client.
//
//   offset  size  field (little-endian)
//        0     4  magic "OMAP"
//        4     1  version, 1
//        5     1  cell coding, 1: two bits per cell
//        6     2  header size in bytes (64): the cells start there
//        8     4  width, cells per row (uint32)
//       12     4  height, rows (uint32)
//       16     8  seq, the map's number since its daemon started (int64)
//       24     8  utime, capture time of the map's newest frame, us since the Unix epoch (int64)
//       32     8  cell_size_m (float64)
//       40     8  origin_x_m, the outer corner of cell (row 0, column 0) (float64)
//       48     8  origin_y_m (float64)
//       56     8  recv_utime, when `occmap web` received the map, us since the Unix epoch (int64)
//       64     …  ceil(width * height / 4) bytes: cell i = row * width + column (row 0 = smallest
//                 y) in bits 2(i mod 4) and 2(i mod 4) + 1 of byte i / 4; 0 free, 1 occupied,
//                 2 unseen (3 is never sent)

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "core/map_geometry.h"

namespace occmap::web {

inline constexpr std::uint8_t kMapFrameVersion = 1;
inline constexpr std::uint8_t kMapFrameTwoBitCells = 1;
inline constexpr std::size_t kMapFrameHeaderSize = 64;

// The message of a map (cells 0, 1 or 2, width * height of them, as OccupancyMap holds them).
std::vector<std::uint8_t> encodeMapFrame(const OccupancyMap& map, std::int64_t seq,
                                         std::int64_t utime, std::int64_t recv_utime);

// A map frame read back (for tests, and as the reference of what the page's decoder does).
struct MapFrameContents {
  std::int64_t seq = 0;
  std::int64_t utime = 0;
  std::int64_t recv_utime = 0;
  OccupancyMap map;
};
// Nothing when the bytes are not exactly one map frame of this version.
std::optional<MapFrameContents> decodeMapFrame(std::span<const std::uint8_t> bytes);

}  // namespace occmap::web
