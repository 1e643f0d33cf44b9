#include "web/map_wire.h"

#include <bit>
#include <cmath>
#include <cstring>

#include "transport/map_codec.h"

namespace occmap::web {
namespace {

constexpr std::uint8_t kMagic[4] = {'O', 'M', 'A', 'P'};

void putLittleEndian(std::uint8_t* at, std::uint64_t value, int bytes) {
  for (int k = 0; k < bytes; ++k) at[k] = static_cast<std::uint8_t>(value >> (8 * k));
}

std::uint64_t getLittleEndian(const std::uint8_t* at, int bytes) {
  std::uint64_t value = 0;
  for (int k = 0; k < bytes; ++k) value |= std::uint64_t{at[k]} << (8 * k);
  return value;
}

}  // namespace

std::vector<std::uint8_t> encodeMapFrame(const OccupancyMap& map, std::int64_t seq,
                                         std::int64_t utime, std::int64_t recv_utime) {
  const MapGeometry& g = map.geometry;
  const std::size_t cells = map.cells.size();
  std::vector<std::uint8_t> frame(kMapFrameHeaderSize + (cells + 3) / 4, 0);
  std::uint8_t* h = frame.data();
  std::memcpy(h, kMagic, sizeof kMagic);
  h[4] = kMapFrameVersion;
  h[5] = kMapFrameTwoBitCells;
  putLittleEndian(h + 6, kMapFrameHeaderSize, 2);
  putLittleEndian(h + 8, static_cast<std::uint32_t>(g.width), 4);
  putLittleEndian(h + 12, static_cast<std::uint32_t>(g.height), 4);
  putLittleEndian(h + 16, static_cast<std::uint64_t>(seq), 8);
  putLittleEndian(h + 24, static_cast<std::uint64_t>(utime), 8);
  putLittleEndian(h + 32, std::bit_cast<std::uint64_t>(g.cell_size_m), 8);
  putLittleEndian(h + 40, std::bit_cast<std::uint64_t>(g.origin_x_m), 8);
  putLittleEndian(h + 48, std::bit_cast<std::uint64_t>(g.origin_y_m), 8);
  putLittleEndian(h + 56, static_cast<std::uint64_t>(recv_utime), 8);
  std::uint8_t* packed = h + kMapFrameHeaderSize;
  for (std::size_t i = 0; i < cells; ++i) {
    const auto value = static_cast<std::uint8_t>(map.cells[i]) & 3u;
    packed[i / 4] = static_cast<std::uint8_t>(packed[i / 4] | value << (2 * (i % 4)));
  }
  return frame;
}

std::optional<MapFrameContents> decodeMapFrame(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < kMapFrameHeaderSize) return std::nullopt;
  const std::uint8_t* h = bytes.data();
  if (std::memcmp(h, kMagic, sizeof kMagic) != 0 || h[4] != kMapFrameVersion ||
      h[5] != kMapFrameTwoBitCells || getLittleEndian(h + 6, 2) != kMapFrameHeaderSize) {
    return std::nullopt;
  }
  const std::uint64_t width = getLittleEndian(h + 8, 4);
  const std::uint64_t height = getLittleEndian(h + 12, 4);
  if (width < 1 || height < 1 || width > static_cast<std::uint64_t>(kMaxMapSide) ||
      height > static_cast<std::uint64_t>(kMaxMapSide)) {
    return std::nullopt;
  }
  const std::uint64_t cells = width * height;
  if (bytes.size() != kMapFrameHeaderSize + (cells + 3) / 4) return std::nullopt;
  MapGeometry g;
  g.width = static_cast<int>(width);
  g.height = static_cast<int>(height);
  g.cell_size_m = std::bit_cast<double>(getLittleEndian(h + 32, 8));
  g.origin_x_m = std::bit_cast<double>(getLittleEndian(h + 40, 8));
  g.origin_y_m = std::bit_cast<double>(getLittleEndian(h + 48, 8));
  if (!std::isfinite(g.cell_size_m) || g.cell_size_m <= 0) return std::nullopt;
  MapFrameContents contents{static_cast<std::int64_t>(getLittleEndian(h + 16, 8)),
                            static_cast<std::int64_t>(getLittleEndian(h + 24, 8)),
                            static_cast<std::int64_t>(getLittleEndian(h + 56, 8)), OccupancyMap(g)};
  const std::uint8_t* packed = h + kMapFrameHeaderSize;
  for (std::size_t i = 0; i < cells; ++i) {
    const unsigned value = packed[i / 4] >> (2 * (i % 4)) & 3u;
    if (value > 2) return std::nullopt;
    contents.map.cells[i] = static_cast<CellState>(value);
  }
  return contents;
}

}  // namespace occmap::web
