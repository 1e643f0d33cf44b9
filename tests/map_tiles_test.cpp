// Maps larger than one datagram, in tiles (transport/map_tiles.h, lcmtypes/map_tile_t.lcm): maps of
// every size come back cell for cell from their tiles in both encodings, every tile message is at
// most 61440 bytes whatever the cells; tiles in any order, copies, a tile lost (its cells unseen,
// counted), late tiles and a restarted publisher are handled; damaged and hostile tiles are
// refused with a reason and never make a map; the encoder allocates nothing per map. Then the
// pieces around it: MapReceiver hears maps whole and tiled, MapPublisher publishes tiles and
// counts each failed one, and the config's transport.tiles.
#include "transport/map_tiles.h"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <set>

#include <gtest/gtest.h>
#include <occmap/map_frame_t.hpp>
#include <zstd.h>

#include "allocation_counter.h"
#include "config/config.h"
#include "config/input_error.h"
#include "damaged_bytes.h"
#include "map_scenes.h"
#include "tiled_maps.h"
#include "transport/map_publisher.h"
#include "transport/map_receiver.h"
#include "transport/memory_bus.h"

namespace occmap {
namespace {

using testing::AllocationCounter;
using testing::fillRandom;
using testing::fillScene;
using testing::sceneCameraNames;

using Bytes = std::vector<std::uint8_t>;

// A map given out by an assembler, copied.
struct Given {
  DecodedMap map;
  MapTiles tiles;
};

// An assembler that keeps what it gives out.
struct Collector {
  std::vector<Given> maps;
  MapTileAssembler assembler{[this](const DecodedMap& map, const MapTiles& tiles) {
    maps.push_back({map, tiles});
  }};
  bool take(const Bytes& bytes, std::int64_t recv_utime = 0) {
    return assembler.take(bytes.data(), bytes.size(), recv_utime);
  }
};

enum class Cells { kScene, kRandom, kFree, kUnseen };

MapFrame makeFrame(const MapGeometry& geometry, std::size_t cameras, std::int64_t number,
                   Cells cells) {
  MapFrame frame(geometry, cameras);
  frame.utime = 1'700'000'000'000'000 + number * 33'333;
  switch (cells) {
    case Cells::kScene:
      fillScene(frame, number);
      break;
    case Cells::kRandom:
      fillRandom(frame, number);
      break;
    case Cells::kFree:
    case Cells::kUnseen:
      fillScene(frame, number);  // the cameras
      std::fill(frame.map.cells.begin(), frame.map.cells.end(),
                cells == Cells::kFree ? CellState::kFree : CellState::kUnseen);
      break;
  }
  return frame;
}

// Every tile's message of `frame`.
std::vector<Bytes> encodeTiles(MapTileEncoder& encoder, const MapFrame& frame) {
  std::vector<Bytes> tiles;
  for (int index = 0; index < encoder.tileCount(); ++index) {
    const auto message = encoder.encode(frame, index);
    EXPECT_FALSE(message.empty()) << "tile " << index << ": " << encoder.lastError();
    tiles.emplace_back(message.begin(), message.end());
  }
  return tiles;
}

// Whether cell `cell` lies in one of the tiles `missing` of a map cut into tiles of `side`.
bool inMissingTile(const MapGeometry& g, int side, const std::set<int>& missing, std::size_t cell) {
  const int columns = (g.width + side - 1) / side;
  const auto w = static_cast<std::size_t>(g.width);
  const int row = static_cast<int>(cell / w), column = static_cast<int>(cell % w);
  return missing.count(row / side * columns + column / side) != 0;
}

// `got` is `sent`, cell for cell, but UNSEEN in the tiles `missing`.
void expectSameMap(const MapFrame& sent, const DecodedMap& got,
                   const std::vector<std::string>& names, int side,
                   const std::set<int>& missing = {}) {
  ASSERT_TRUE(got.ok()) << got.error;
  EXPECT_EQ(got.seq, sent.seq);
  EXPECT_EQ(got.utime, sent.utime);
  EXPECT_EQ(got.geometry.width, sent.map.geometry.width);
  EXPECT_EQ(got.geometry.height, sent.map.geometry.height);
  EXPECT_EQ(got.geometry.cell_size_m, sent.map.geometry.cell_size_m);
  EXPECT_EQ(got.geometry.origin_x_m, sent.map.geometry.origin_x_m);
  EXPECT_EQ(got.geometry.origin_y_m, sent.map.geometry.origin_y_m);
  ASSERT_EQ(got.cells.size(), sent.map.cells.size());
  std::size_t wrong = 0, first_wrong = 0;
  for (std::size_t i = 0; i < got.cells.size(); ++i) {
    const auto expected = inMissingTile(sent.map.geometry, side, missing, i)
                              ? static_cast<std::uint8_t>(CellState::kUnseen)
                              : static_cast<std::uint8_t>(sent.map.cells[i]);
    if (got.cells[i] != expected && wrong++ == 0) first_wrong = i;
  }
  EXPECT_EQ(wrong, 0u) << "cells differ, the first at index " << first_wrong;
  ASSERT_EQ(got.cameras.size(), sent.cameras.size());
  for (std::size_t k = 0; k < sent.cameras.size(); ++k) {
    EXPECT_EQ(got.cameras[k].name, names[k]);
    EXPECT_EQ(got.cameras[k].state, sent.cameras[k].state) << "camera " << k;
    EXPECT_EQ(got.cameras[k].used, sent.cameras[k].used) << "camera " << k;
    EXPECT_EQ(got.cameras[k].sequence, sent.cameras[k].sequence) << "camera " << k;
    EXPECT_EQ(got.cameras[k].capture_utime, sent.cameras[k].capture_time_us) << "camera " << k;
  }
}

TEST(MapTiles, ChannelIsTheMapChannelPlusTiles) {
  EXPECT_EQ(tilesChannel("OCCMAP_MAP"), "OCCMAP_MAP_TILES");
  EXPECT_EQ(tilesChannel("OCCMAP_MAP_WEST"), "OCCMAP_MAP_WEST_TILES");
}

// Maps of every shape, cells of every kind, both encodings: back cell for cell, every message at
// most 61440 bytes.
TEST(MapTiles, RoundTripsMapsOfEverySize) {
  const std::vector<std::string> names = {"c0", "left door", "a-much-longer-camera-name-3"};
  const MapGeometry geometries[] = {{0, 0, 1.0, 1, 1},
                                    {-1.25, 2.5, 0.035, 239, 241},
                                    {-0.5, -1.5, 0.02, 240, 240},
                                    {-0.5, -1.5, 0.02, 481, 17},
                                    {-20.0, -20.0, 0.02, 2048, 2048}};
  std::size_t largest = 0;
  for (const MapGeometry& geometry : geometries) {
    for (const MapEncoding encoding : {MapEncoding::kRaw, MapEncoding::kZstd}) {
      MapTileEncoder encoder(geometry, names, encoding);
      EXPECT_EQ(encoder.tileSide(), kPreferredTileSide);
      const int side = encoder.tileSide();
      EXPECT_EQ(encoder.tileCount(),
                ((geometry.width + side - 1) / side) * ((geometry.height + side - 1) / side));
      Collector collector;
      std::int64_t number = 0;
      for (const Cells cells : {Cells::kScene, Cells::kRandom, Cells::kFree, Cells::kUnseen}) {
        const MapFrame frame = makeFrame(geometry, names.size(), number++, cells);
        const std::vector<Bytes> tiles = encodeTiles(encoder, frame);
        for (const Bytes& tile : tiles) {
          EXPECT_LE(tile.size(), kMaxTileMessageSize);
          largest = std::max(largest, tile.size());
          ASSERT_TRUE(collector.take(tile)) << collector.assembler.lastError();
        }
        SCOPED_TRACE(std::to_string(geometry.width) + " x " + std::to_string(geometry.height) +
                     " " + mapEncodingName(encoding) + " map " + std::to_string(frame.seq));
        ASSERT_EQ(collector.maps.size(), static_cast<std::size_t>(number))
            << "a map is given out as soon as its last tile comes";
        const Given& given = collector.maps.back();
        EXPECT_EQ(given.tiles.count, encoder.tileCount());
        EXPECT_EQ(given.tiles.missing, 0);
        expectSameMap(frame, given.map, names, side);
        std::size_t bytes = 0;
        for (const Bytes& tile : tiles) bytes += tile.size();
        EXPECT_EQ(given.map.message_size, bytes);
      }
      EXPECT_EQ(collector.assembler.counters().maps_complete, 4u);
      EXPECT_EQ(collector.assembler.counters().tiles_lost, 0u);
      EXPECT_EQ(collector.assembler.counters().tiles_refused, 0u);
    }
  }
  std::printf("largest tile message: %zu bytes (at most %zu)\n", largest, kMaxTileMessageSize);
}

// A tile zstd cannot shrink (one cell: the frame's own header is larger) goes raw, and a zstd map's
// tiles of many cells go zstd.
TEST(MapTiles, ATileZstdWouldGrowGoesRaw) {
  MapTileEncoder tiny({0, 0, 1.0, 1, 1}, {"c0"}, MapEncoding::kZstd);
  MapFrame one = makeFrame({0, 0, 1.0, 1, 1}, 1, 0, Cells::kFree);
  const auto message = tiny.encode(one, 0);
  ASSERT_FALSE(message.empty());
  occmap::map_tile_t decoded{};
  ASSERT_EQ(decoded.decode(message.data(), 0, static_cast<int>(message.size())),
            static_cast<int>(message.size()));
  EXPECT_EQ(decoded.encoding, occmap::map_tile_t::ENCODING_RAW);
  EXPECT_EQ(decoded.data_size, 1);

  MapTileEncoder big({0, 0, 0.02, 2048, 2048}, {"c0"}, MapEncoding::kZstd);
  const auto scene = big.encode(makeFrame({0, 0, 0.02, 2048, 2048}, 1, 0, Cells::kScene), 40);
  ASSERT_EQ(decoded.decode(scene.data(), 0, static_cast<int>(scene.size())),
            static_cast<int>(scene.size()));
  EXPECT_EQ(decoded.encoding, occmap::map_tile_t::ENCODING_ZSTD);
  EXPECT_LT(decoded.data_size, 240 * 240);
}

// A long camera list makes tiles smaller so that every message still fits; one that leaves no
// room for a 16 x 16 tile is refused.
TEST(MapTiles, ALongCameraListMakesSmallerTilesThatStillFit) {
  std::vector<std::string> names;
  for (int k = 0; k < 100; ++k) names.push_back(std::string(60, 'a') + std::to_string(k));
  const MapGeometry geometry{0, 0, 0.02, 1000, 700};
  MapTileEncoder encoder(geometry, names, MapEncoding::kRaw);
  EXPECT_LT(encoder.tileSide(), kPreferredTileSide);
  EXPECT_GE(encoder.tileSide(), 200);
  Collector collector;
  const MapFrame frame = makeFrame(geometry, names.size(), 5, Cells::kRandom);
  for (const Bytes& tile : encodeTiles(encoder, frame)) {
    EXPECT_LE(tile.size(), kMaxTileMessageSize);
    ASSERT_TRUE(collector.take(tile)) << collector.assembler.lastError();
  }
  ASSERT_EQ(collector.maps.size(), 1u);
  expectSameMap(frame, collector.maps[0].map, names, encoder.tileSide());

  std::vector<std::string> too_many(2000, std::string(64, 'b'));
  EXPECT_THROW(MapTileEncoder(geometry, too_many, MapEncoding::kZstd), std::invalid_argument);
  EXPECT_THROW(MapTileEncoder({0, 0, 0.02, 8193, 1}, {}, MapEncoding::kRaw), std::invalid_argument);
  EXPECT_THROW(MapTileEncoder({0, 0, 0.02, 0, 5}, {}, MapEncoding::kRaw), std::invalid_argument);
}

TEST(MapTiles, EncoderRefusesFramesThatDoNotFit) {
  MapTileEncoder encoder({0, 0, 0.02, 300, 200}, sceneCameraNames(2), MapEncoding::kZstd);
  EXPECT_TRUE(encoder.encode(MapFrame({0, 0, 0.02, 200, 300}, 2), 0).empty());
  EXPECT_STRNE(encoder.lastError(), "");
  EXPECT_TRUE(encoder.encode(MapFrame({0, 0, 0.02, 300, 200}, 3), 0).empty());
  EXPECT_TRUE(encoder.encode(MapFrame({0, 0, 0.02, 300, 200}, 2), -1).empty());
  EXPECT_TRUE(encoder.encode(MapFrame({0, 0, 0.02, 300, 200}, 2), 2).empty());
  EXPECT_FALSE(encoder.encode(MapFrame({0, 0, 0.02, 300, 200}, 2), 1).empty());
  EXPECT_STREQ(encoder.lastError(), "");
}

TEST(MapTiles, EncoderAllocatesNothingPerMap) {
  const MapGeometry geometry{-20.0, -20.0, 0.02, 2048, 2048};
  const auto names = sceneCameraNames(4);
  std::vector<MapFrame> frames;
  for (std::int64_t n = 0; n < 3; ++n) {
    frames.push_back(makeFrame(geometry, names.size(), n, n == 1 ? Cells::kRandom : Cells::kScene));
  }
  for (const MapEncoding encoding : {MapEncoding::kRaw, MapEncoding::kZstd}) {
    MapTileEncoder encoder(geometry, names, encoding);
    std::size_t total = 0;
    long allocations = 0;
    {
      AllocationCounter counter;
      for (int round = 0; round < 2; ++round) {
        for (const MapFrame& frame : frames) {
          for (int index = 0; index < encoder.tileCount(); ++index) {
            total += encoder.encode(frame, index).size();
          }
        }
      }
      allocations = counter.allocations();
    }
    EXPECT_EQ(allocations, 0) << mapEncodingName(encoding) << ": encode() allocated";
    EXPECT_GT(total, 0u);
  }
}

// Once it has held a map of a size, the assembler puts the next ones together without allocating.
TEST(MapTiles, AssemblerAllocatesNothingOnceWarm) {
  const MapGeometry geometry{-0.5, -1.5, 0.02, 1000, 600};
  const auto names = sceneCameraNames(4);
  MapTileEncoder encoder(geometry, names, MapEncoding::kZstd);
  std::vector<std::vector<Bytes>> maps;
  for (std::int64_t n = 0; n < 4; ++n) {
    maps.push_back(encodeTiles(encoder, makeFrame(geometry, names.size(), n, Cells::kScene)));
  }
  int given = 0;
  MapTileAssembler assembler([&given](const DecodedMap&, const MapTiles&) { ++given; });
  for (const Bytes& tile : maps[0]) assembler.take(tile.data(), tile.size());
  long allocations = 0;
  {
    AllocationCounter counter;
    for (std::size_t m = 1; m < maps.size(); ++m) {
      for (const Bytes& tile : maps[m]) assembler.take(tile.data(), tile.size());
    }
    allocations = counter.allocations();
  }
  EXPECT_EQ(given, 4);
  EXPECT_EQ(allocations, 0);
}

// ---------------------------------------------------------------------------------------------
// What the network does to tiles

struct TiledMaps {
  MapGeometry geometry{-0.5, -1.5, 0.02, 700, 500};  // 3 x 3 tiles, the last column and row narrow
  std::vector<std::string> names = sceneCameraNames(3);
  MapTileEncoder encoder{geometry, names, MapEncoding::kZstd};
  std::vector<MapFrame> frames;
  std::vector<std::vector<Bytes>> tiles;
  explicit TiledMaps(int count, Cells cells = Cells::kScene) {
    for (std::int64_t n = 0; n < count; ++n) {
      frames.push_back(makeFrame(geometry, names.size(), n, cells));
      tiles.push_back(encodeTiles(encoder, frames.back()));
    }
  }
};

TEST(MapTileAssembler, TakesTilesInAnyOrderAndIgnoresCopies) {
  TiledMaps maps(3);
  ASSERT_EQ(maps.encoder.tileCount(), 9);
  std::mt19937 rng(5);
  Collector collector;
  for (std::size_t m = 0; m < maps.frames.size(); ++m) {
    std::vector<Bytes> shuffled = maps.tiles[m];
    shuffled.push_back(shuffled[3]);  // copies, one of them after the map is complete
    shuffled.push_back(shuffled[0]);
    std::shuffle(shuffled.begin(), shuffled.end() - 1, rng);
    for (const Bytes& tile : shuffled) {
      ASSERT_TRUE(collector.take(tile)) << collector.assembler.lastError();
    }
    ASSERT_EQ(collector.maps.size(), m + 1) << "each map once, however its tiles came";
    EXPECT_EQ(collector.maps.back().tiles.missing, 0);
    expectSameMap(maps.frames[m], collector.maps.back().map, maps.names, maps.encoder.tileSide());
  }
  const MapTileCounters& c = collector.assembler.counters();
  EXPECT_EQ(c.maps_complete, 3u);
  EXPECT_EQ(c.maps_incomplete, 0u);
  EXPECT_EQ(c.tiles_taken, 27u);
  EXPECT_EQ(c.tiles_stale, 6u);
  EXPECT_EQ(c.tiles_refused, 0u);
}

TEST(MapTileAssembler, ALostTileIsUnseenAndCountedWhenTheNextMapBegins) {
  TiledMaps maps(3);
  Collector collector;
  for (std::size_t i = 0; i < maps.tiles[0].size(); ++i) {
    if (i != 4) collector.take(maps.tiles[0][i], 1000 + static_cast<std::int64_t>(i));
  }
  EXPECT_TRUE(collector.maps.empty()) << "map 0 could still be completed";
  collector.take(maps.tiles[1][7]);  // map 1 begins: map 0 will never be
  ASSERT_EQ(collector.maps.size(), 1u);
  const Given& first = collector.maps[0];
  EXPECT_EQ(first.tiles.count, 9);
  EXPECT_EQ(first.tiles.missing, 1);
  EXPECT_EQ(first.tiles.recv_utime, 1008) << "when the last tile that came was received";
  expectSameMap(maps.frames[0], first.map, maps.names, maps.encoder.tileSide(), {4});
  // The lost tile's cells are unseen, whatever they were.
  const MapFrame& sent = maps.frames[0];
  std::size_t changed = 0;
  for (std::size_t i = 0; i < sent.map.cells.size(); ++i) {
    changed += sent.map.cells[i] != CellState::kUnseen &&
               first.map.cells[i] == static_cast<std::uint8_t>(CellState::kUnseen);
  }
  EXPECT_GT(changed, 10000u) << "tile 4 is the middle of the room: mostly seen";

  // Two tiles of map 1 lost, map 2 complete: map 1 goes out with 2 missing, map 2 whole.
  for (std::size_t i = 0; i < maps.tiles[1].size(); ++i) {
    if (i != 0 && i != 8 && i != 7) collector.take(maps.tiles[1][i]);
  }
  for (const Bytes& tile : maps.tiles[2]) collector.take(tile);
  ASSERT_EQ(collector.maps.size(), 3u);
  EXPECT_EQ(collector.maps[1].tiles.missing, 2);
  expectSameMap(maps.frames[1], collector.maps[1].map, maps.names, maps.encoder.tileSide(), {0, 8});
  EXPECT_EQ(collector.maps[2].tiles.missing, 0);
  const MapTileCounters& c = collector.assembler.counters();
  EXPECT_EQ(c.maps_complete, 1u);
  EXPECT_EQ(c.maps_incomplete, 2u);
  EXPECT_EQ(c.tiles_lost, 3u);
}

TEST(MapTileAssembler, LateTilesOfOlderMapsAreLeftOut) {
  TiledMaps maps(3);
  Collector collector;
  for (std::size_t i = 1; i < 9; ++i) collector.take(maps.tiles[0][i]);
  for (std::size_t i = 0; i < 5; ++i) collector.take(maps.tiles[1][i]);
  ASSERT_EQ(collector.maps.size(), 1u);
  // Tile 0 of map 0 comes late, after map 0 went out and map 1 began: left out.
  EXPECT_TRUE(collector.take(maps.tiles[0][0]));
  EXPECT_EQ(collector.maps.size(), 1u);
  EXPECT_EQ(collector.assembler.counters().tiles_stale, 1u);
  for (std::size_t i = 5; i < 9; ++i) collector.take(maps.tiles[1][i]);
  ASSERT_EQ(collector.maps.size(), 2u);
  EXPECT_EQ(collector.maps[1].tiles.missing, 0);
  // And a tile of map 1 once map 1 is out, or of map 0: left out, no new map begun.
  collector.take(maps.tiles[1][2]);
  collector.take(maps.tiles[0][3]);
  EXPECT_EQ(collector.maps.size(), 2u);
  collector.assembler.flush();
  EXPECT_EQ(collector.maps.size(), 2u) << "nothing in progress";
  EXPECT_EQ(collector.assembler.counters().tiles_stale, 3u);
}

// A publisher that restarts numbers its maps from 0 again, with newer captures: a new map, not a
// late one.
TEST(MapTileAssembler, ARestartedPublisherIsTakenAtOnce) {
  TiledMaps maps(1);
  MapFrame later = maps.frames[0];
  MapFrame restarted = maps.frames[0];
  later.seq = 500;
  restarted.seq = 0;
  restarted.utime = later.utime + 5'000'000;
  Collector collector;
  for (const Bytes& tile : encodeTiles(maps.encoder, later)) collector.take(tile);
  for (const Bytes& tile : encodeTiles(maps.encoder, restarted)) collector.take(tile);
  ASSERT_EQ(collector.maps.size(), 2u);
  EXPECT_EQ(collector.maps[1].map.seq, 0);
  EXPECT_EQ(collector.maps[1].tiles.missing, 0);
}

TEST(MapTileAssembler, FlushGivesOutTheMapInProgress) {
  TiledMaps maps(1);
  Collector collector;
  for (std::size_t i = 0; i < 6; ++i) collector.take(maps.tiles[0][i]);
  collector.assembler.flush();
  ASSERT_EQ(collector.maps.size(), 1u);
  EXPECT_EQ(collector.maps[0].tiles.missing, 3);
  expectSameMap(maps.frames[0], collector.maps[0].map, maps.names, maps.encoder.tileSide(),
                {6, 7, 8});
  collector.take(maps.tiles[0][7]);  // too late now
  collector.assembler.flush();
  EXPECT_EQ(collector.maps.size(), 1u);
}

// ---------------------------------------------------------------------------------------------
// Hostile tiles

// Where the fields sit in an encoded map_tile_t (after the 8-byte fingerprint).
constexpr std::size_t kWidthAt = 24, kHeightAt = 28, kCellSizeAt = 32, kOriginXAt = 40,
                      kSideAt = 56, kFirstColumnAt = 60, kFirstRowAt = 64, kTileWidthAt = 68,
                      kTileHeightAt = 72, kIndexAt = 76, kCountAt = 80, kEncodingAt = 84,
                      kDataSizeAt = 85, kDataAt = 89;

void putBigEndian(Bytes& bytes, std::size_t at, std::uint64_t value, int size) {
  for (int i = 0; i < size; ++i) {
    bytes[at + static_cast<std::size_t>(i)] =
        static_cast<std::uint8_t>(value >> (8 * (size - 1 - i)));
  }
}

// A tile message built field by field, so that tests can break any field consistently.
struct TileBuilder {
  occmap::map_tile_t message{};
  TileBuilder() {
    message.utime = 1;
    message.seq = 7;
    message.width = 40;
    message.height = 30;
    message.cell_size_m = 0.02;
    message.tile_side = 16;
    message.tile_count = 6;  // 3 x 2
    message.tile_index = 2;
    message.first_column = 32;
    message.first_row = 0;
    message.tile_width = 8;
    message.tile_height = 16;
    setCells(std::vector<std::uint8_t>(8 * 16, 1), MapEncoding::kRaw);
    message.num_cameras = 2;
    for (int k = 0; k < 2; ++k) {
      occmap::camera_frame_t camera{};
      camera.name = "cam" + std::to_string(k);
      camera.state = 1;
      camera.used = true;
      camera.sequence = 3;
      camera.capture_utime = 2;
      message.cameras.push_back(camera);
    }
  }
  void setCells(const std::vector<std::uint8_t>& cells, MapEncoding encoding) {
    message.encoding = static_cast<std::int8_t>(encoding);
    if (encoding == MapEncoding::kRaw) {
      message.data = cells;
    } else {
      message.data.resize(ZSTD_compressBound(cells.size()));
      message.data.resize(
          ZSTD_compress(message.data.data(), message.data.size(), cells.data(), cells.size(), 1));
    }
    message.data_size = static_cast<std::int32_t>(message.data.size());
  }
  Bytes bytes() const {
    Bytes out(static_cast<std::size_t>(message.getEncodedSize()));
    EXPECT_EQ(message.encode(out.data(), 0, static_cast<int>(out.size())),
              static_cast<int>(out.size()));
    return out;
  }
};

// Takes `bytes` into a fresh assembler: refused with `why` in the text, no map given out, nothing
// allocated beyond the message, a tile or the map its header declares.
void expectRefused(const Bytes& bytes, const std::string& why) {
  Collector collector;
  std::size_t largest = 0;
  bool taken = true;
  {
    AllocationCounter counter;
    taken = collector.take(bytes);
    largest = counter.largest();
  }
  EXPECT_FALSE(taken) << "accepted a tile that should be refused for: " << why;
  const std::string& error = collector.assembler.lastError();
  EXPECT_NE(error.find(why), std::string::npos)
      << "refused for '" << error << "', expected '" << why << "'";
  EXPECT_EQ(collector.assembler.counters().tiles_refused, 1u);
  collector.assembler.flush();
  EXPECT_TRUE(collector.maps.empty()) << "a refused tile made a map";
  EXPECT_LE(largest, std::max<std::size_t>(bytes.size(), 4096))
      << "allocated " << largest << " bytes for a refused " << bytes.size() << "-byte tile";
}

TEST(MapTileAssembler, TheBuilderMakesAGoodTile) {
  Collector collector;
  ASSERT_TRUE(collector.take(TileBuilder().bytes())) << collector.assembler.lastError();
  collector.assembler.flush();
  ASSERT_EQ(collector.maps.size(), 1u);
  EXPECT_EQ(collector.maps[0].tiles.missing, 5);
}

TEST(MapTileAssembler, RefusesEveryTruncation) {
  for (const MapEncoding encoding : {MapEncoding::kRaw, MapEncoding::kZstd}) {
    TileBuilder builder;
    builder.setCells(std::vector<std::uint8_t>(8 * 16, 2), encoding);
    const Bytes bytes = builder.bytes();
    Collector collector;
    for (std::size_t size = 0; size < bytes.size(); ++size) {
      const Bytes cut(bytes.begin(), bytes.begin() + static_cast<long>(size));
      EXPECT_FALSE(collector.take(cut)) << mapEncodingName(encoding) << ": accepted " << size
                                        << " of " << bytes.size() << " bytes";
      EXPECT_NE(collector.assembler.lastError(), "");
    }
    EXPECT_FALSE(collector.assembler.take(nullptr, 0));
    collector.assembler.flush();
    EXPECT_TRUE(collector.maps.empty());
  }
  expectRefused({1, 2, 3}, "too short");
  expectRefused(Bytes(60, 0), "not an occmap.map_tile_t: fingerprint");
}

TEST(MapTileAssembler, RefusesOtherTypesAndTrailingBytes) {
  // A whole map sent on the tiles channel.
  occmap::map_frame_t frame{};
  frame.width = frame.height = 1;
  frame.cell_size_m = 1;
  frame.data = {0};
  frame.data_size = 1;
  Bytes frame_bytes(static_cast<std::size_t>(frame.getEncodedSize()));
  frame.encode(frame_bytes.data(), 0, static_cast<int>(frame_bytes.size()));
  expectRefused(frame_bytes, "not an occmap.map_tile_t");
  Bytes bytes = TileBuilder().bytes();
  bytes.push_back(0);
  expectRefused(bytes, "1 bytes left over");
}

TEST(MapTileAssembler, RefusesBadMapHeaders) {
  const Bytes good = TileBuilder().bytes();
  Bytes bytes = good;
  putBigEndian(bytes, kWidthAt, 0, 4);
  expectRefused(bytes, "the map's width 0 is outside 1..8192");
  bytes = good;
  putBigEndian(bytes, kHeightAt, 9000, 4);
  expectRefused(bytes, "the map's height 9000 is outside 1..8192");
  bytes = good;
  putBigEndian(bytes, kCellSizeAt, std::bit_cast<std::uint64_t>(-0.02), 8);
  expectRefused(bytes, "is not a positive number");
  bytes = good;
  putBigEndian(bytes, kOriginXAt,
               std::bit_cast<std::uint64_t>(std::numeric_limits<double>::infinity()), 8);
  expectRefused(bytes, "is not finite");
  bytes = good;
  bytes[kEncodingAt] = 5;
  expectRefused(bytes, "unknown encoding 5");
}

TEST(MapTileAssembler, RefusesTilesNotInTheirPlace) {
  const Bytes good = TileBuilder().bytes();
  Bytes bytes = good;
  putBigEndian(bytes, kSideAt, 8, 4);
  expectRefused(bytes, "tile_side 8 is outside 16..247");
  bytes = good;
  putBigEndian(bytes, kSideAt, 248, 4);
  expectRefused(bytes, "tile_side 248 is outside 16..247");
  bytes = good;
  putBigEndian(bytes, kCountAt, 7, 4);
  expectRefused(bytes, "tile_count 7 is not the 3 x 2 tiles of side 16 that a 40 x 30 map");
  bytes = good;
  putBigEndian(bytes, kIndexAt, 6, 4);
  expectRefused(bytes, "tile_index 6 is outside 0..5");
  bytes = good;
  putBigEndian(bytes, kIndexAt, static_cast<std::uint32_t>(-1), 4);
  expectRefused(bytes, "tile_index -1 is outside 0..5");
  bytes = good;
  putBigEndian(bytes, kIndexAt, 1, 4);  // tile 1 is at column 16
  expectRefused(bytes, "in the grid of side 16 it is 16 x 16 cells at column 16, row 0");
  bytes = good;
  putBigEndian(bytes, kFirstRowAt, 16, 4);
  expectRefused(bytes, "says it is 8 x 16 cells at column 32, row 16");
  bytes = good;
  putBigEndian(bytes, kFirstColumnAt, 30, 4);
  expectRefused(bytes, "at column 30");
  // A tile that says it is larger than its place, its data agreeing: refused by its place.
  TileBuilder wide;
  wide.message.tile_width = 16;
  wide.setCells(std::vector<std::uint8_t>(16 * 16, 0), MapEncoding::kRaw);
  expectRefused(wide.bytes(), "says it is 16 x 16 cells at column 32");
  bytes = good;
  putBigEndian(bytes, kTileHeightAt, 14, 4);
  expectRefused(bytes, "says it is 8 x 14 cells");
  bytes = good;
  putBigEndian(bytes, kTileWidthAt, 0, 4);
  expectRefused(bytes, "says it is 0 x 16 cells");
}

TEST(MapTileAssembler, RefusesDataThatIsNotItsCells) {
  const Bytes good = TileBuilder().bytes();
  Bytes bytes = good;
  putBigEndian(bytes, kDataSizeAt, static_cast<std::uint32_t>(-1), 4);
  expectRefused(bytes, "data_size -1 is negative");
  bytes = good;
  putBigEndian(bytes, kDataSizeAt, 0x7fffffff, 4);
  expectRefused(bytes, "truncated: data_size says 2147483647 bytes");
  TileBuilder short_data;
  short_data.setCells(std::vector<std::uint8_t>(8 * 16 - 1, 0), MapEncoding::kRaw);
  expectRefused(short_data.bytes(), "raw data_size 127 is not tile_width * tile_height = 128");
  for (const MapEncoding encoding : {MapEncoding::kRaw, MapEncoding::kZstd}) {
    TileBuilder three;
    std::vector<std::uint8_t> cells(8 * 16, 0);
    cells[5 * 8 + 3] = 3;
    three.setCells(cells, encoding);
    expectRefused(three.bytes(), "tile 2's cell (row 5, column 35) is 3");
  }
  TileBuilder longer;
  longer.setCells(std::vector<std::uint8_t>(8 * 16 + 1, 0), MapEncoding::kZstd);
  expectRefused(longer.bytes(),
                "the zstd frame says it holds 129 bytes, but tile_width * "
                "tile_height = 128");
  // A frame that claims the largest map: nothing near it is allocated.
  TileBuilder huge;
  huge.setCells(std::vector<std::uint8_t>(8192u * 8192u, 0), MapEncoding::kZstd);
  expectRefused(huge.bytes(), "says it holds 67108864 bytes");
  TileBuilder garbage;
  garbage.setCells(std::vector<std::uint8_t>(8 * 16, 0), MapEncoding::kZstd);
  garbage.message.data[0] ^= 0xff;  // the magic number
  expectRefused(garbage.bytes(), "not a zstd frame");
  TileBuilder empty;
  empty.setCells({}, MapEncoding::kRaw);
  empty.message.encoding = occmap::map_tile_t::ENCODING_ZSTD;
  expectRefused(empty.bytes(), "the zstd data is empty");
  TileBuilder trailing;
  trailing.setCells(std::vector<std::uint8_t>(8 * 16, 0), MapEncoding::kZstd);
  trailing.message.data.push_back(0);
  trailing.message.data_size += 1;
  expectRefused(trailing.bytes(), "1 bytes after its zstd frame");
}

TEST(MapTileAssembler, RefusesMalformedCameras) {
  const Bytes good = TileBuilder().bytes();
  const std::size_t cameras_at = kDataAt + 8 * 16;
  Bytes bytes = good;
  putBigEndian(bytes, cameras_at, 0xffff, 2);
  expectRefused(bytes, "num_cameras -1 is negative");
  bytes = good;
  putBigEndian(bytes, cameras_at, 32767, 2);
  expectRefused(bytes, "camera 2 of 32767");
  bytes = good;
  putBigEndian(bytes, cameras_at + 2, 0x7fffffff, 4);
  expectRefused(bytes, "camera 0 of 2: its name is not");
  bytes = good;
  bytes[cameras_at + 2 + 4 + 4] = 'x';  // "cam0\0" loses its NUL
  expectRefused(bytes, "camera 0 of 2: its name is not");
  bytes = good;
  bytes[cameras_at + 2 + 4 + 5] = 9;
  expectRefused(bytes, "camera 0 of 2: unknown state 9");
  bytes = good;
  bytes[cameras_at + 2 + 4 + 5 + 1] = 2;
  expectRefused(bytes, "not a boolean");
}

// A tile that does not agree with the tiles of its map taken before is refused, and the map goes
// on with the good ones.
TEST(MapTileAssembler, RefusesTilesThatDisagreeWithTheirMap) {
  TiledMaps maps(1);
  Collector collector;
  collector.take(maps.tiles[0][0]);
  MapFrame other = maps.frames[0];
  other.map.geometry.cell_size_m = 0.05;
  const std::vector<Bytes> other_tiles = encodeTiles(maps.encoder, other);
  EXPECT_FALSE(collector.take(other_tiles[1]));
  EXPECT_NE(collector.assembler.lastError().find("another geometry"), std::string::npos)
      << collector.assembler.lastError();
  MapFrame renamed_cameras = maps.frames[0];
  renamed_cameras.cameras[1].used = !renamed_cameras.cameras[1].used;
  const std::vector<Bytes> camera_tiles = encodeTiles(maps.encoder, renamed_cameras);
  EXPECT_FALSE(collector.take(camera_tiles[2]));
  EXPECT_NE(collector.assembler.lastError().find("another camera list"), std::string::npos)
      << collector.assembler.lastError();
  for (std::size_t i = 1; i < maps.tiles[0].size(); ++i) collector.take(maps.tiles[0][i]);
  ASSERT_EQ(collector.maps.size(), 1u);
  EXPECT_EQ(collector.maps[0].tiles.missing, 0);
  expectSameMap(maps.frames[0], collector.maps[0].map, maps.names, maps.encoder.tileSide());
  EXPECT_EQ(collector.assembler.counters().tiles_refused, 2u);
}

// Random damage among good tiles: never a crash, and every map given out is a map (its cells
// 0..2, as many as its geometry says) whose tiles each decoded.
TEST(MapTileAssembler, SurvivesRandomDamage) {
  TiledMaps maps(16, Cells::kRandom);
  std::mt19937 rng(17);
  Collector collector;
  int damaged = 0, accepted_damaged = 0;
  for (const std::vector<Bytes>& tiles : maps.tiles) {
    for (Bytes bytes : tiles) {
      if (rng() % 3 != 0) {
        collector.take(bytes);
        continue;
      }
      ++damaged;
      testing::damageBytes(bytes, rng);
      accepted_damaged += collector.take(bytes);
    }
  }
  collector.assembler.flush();
  for (const Given& given : collector.maps) {
    ASSERT_TRUE(given.map.ok());
    ASSERT_EQ(given.map.cells.size(), given.map.geometry.cellCount());
    for (const std::uint8_t c : given.map.cells) ASSERT_LE(c, 2);
    EXPECT_GE(given.tiles.missing, 0);
    EXPECT_LE(given.tiles.missing, given.tiles.count);
  }
  std::printf(
      "%d damaged tiles, %d of them still decoded (damage to seq, times, raw cells, "
      "camera fields); %zu maps given out, %llu tiles refused\n",
      damaged, accepted_damaged, collector.maps.size(),
      static_cast<unsigned long long>(collector.assembler.counters().tiles_refused));
  EXPECT_GT(collector.assembler.counters().tiles_refused, 0u);
}

// ---------------------------------------------------------------------------------------------
// MapReceiver and MapPublisher on the in-memory bus

void drain(MemoryBus& bus) {
  while (bus.pending() > 0) bus.handleTimeout(0);
}

TEST(MapReceiver, HearsMapsWholeAndTiledWithTheirRefusals) {
  MemoryNetwork network;
  auto daemon = network.connect();
  auto subscriber = network.connect();
  std::vector<std::pair<Given, std::int64_t>> heard;
  std::vector<std::string> refusals;
  MapReceiver* receiver_seen = nullptr;
  MapReceiver receiver(
      *subscriber, "OCCMAP_MAP",
      [&](const DecodedMap& map, std::int64_t recv_utime) {
        heard.push_back({{map, receiver_seen->tilesOfMap()}, recv_utime});
      },
      [&](const std::string& channel, std::size_t size, const std::string& why) {
        refusals.push_back(channel + " " + std::to_string(size) + ": " + why);
      });
  receiver_seen = &receiver;
  ASSERT_TRUE(receiver.subscribed());
  EXPECT_EQ(receiver.tileChannel(), "OCCMAP_MAP_TILES");

  const MapGeometry geometry{-0.5, -1.5, 0.02, 600, 300};
  const auto names = sceneCameraNames(2);
  MapPublisher whole(geometry, names, MapEncoding::kZstd, "OCCMAP_MAP", "memory");
  MapPublisher tiled(geometry, names, MapEncoding::kZstd, "OCCMAP_MAP", "memory",
                     MapMessages::kTiles);
  EXPECT_EQ(tiled.messages(), MapMessages::kTiles);
  MapFrame frame = makeFrame(geometry, names.size(), 0, Cells::kScene);
  ASSERT_TRUE(whole.publish(*daemon, frame));
  drain(*subscriber);
  ASSERT_EQ(heard.size(), 1u);
  EXPECT_EQ(heard[0].first.tiles.count, 0) << "a whole map";
  expectSameMap(frame, heard[0].first.map, names, kPreferredTileSide);

  for (int n = 0; n < 3; ++n) {
    frame = makeFrame(geometry, names.size(), n, Cells::kScene);
    ASSERT_TRUE(tiled.publish(*daemon, frame));  // numbered 0, 1, 2 by the publisher
  }
  drain(*subscriber);
  ASSERT_EQ(heard.size(), 4u);
  for (int n = 0; n < 3; ++n) {
    const Given& given = heard[static_cast<std::size_t>(n) + 1].first;
    EXPECT_EQ(given.tiles.count, 6);
    EXPECT_EQ(given.tiles.missing, 0);
    EXPECT_EQ(given.map.seq, n);
    EXPECT_GT(heard[static_cast<std::size_t>(n) + 1].second, 0) << "the receive time";
  }
  expectSameMap(frame, heard[3].first.map, names, kPreferredTileSide);
  EXPECT_EQ(tiled.published(), 3u);
  EXPECT_EQ(tiled.errors(), 0u);

  daemon->publish("OCCMAP_MAP", Bytes(100, 1));
  daemon->publish("OCCMAP_MAP_TILES", Bytes(100, 2));
  drain(*subscriber);
  ASSERT_EQ(refusals.size(), 2u);
  EXPECT_NE(refusals[0].find("OCCMAP_MAP 100: not an occmap.map_frame_t"), std::string::npos)
      << refusals[0];
  EXPECT_NE(refusals[1].find("OCCMAP_MAP_TILES 100: not an occmap.map_tile_t"), std::string::npos)
      << refusals[1];
  const MapReceiverCounters counters = receiver.counters();
  EXPECT_EQ(counters.maps, 4u);
  EXPECT_EQ(counters.whole_maps, 1u);
  EXPECT_EQ(counters.undecodable, 1u);
  EXPECT_EQ(counters.tiles.maps_complete, 3u);
  EXPECT_EQ(counters.tiles.tiles_refused, 1u);
  EXPECT_EQ(counters.last_error.rfind("OCCMAP_MAP_TILES: not an occmap.map_tile_t", 0), 0u)
      << counters.last_error;
}

// A bus on which every third publish fails, as a full socket buffer makes it fail.
class FlakyBus final : public Bus {
 public:
  explicit FlakyBus(Bus& inner) : inner_(inner) {}
  bool publish(const std::string& channel, std::span<const std::uint8_t> message) override {
    if (++sent_ % 3 == 0) {
      errno = ENOBUFS;
      return false;
    }
    return inner_.publish(channel, message);
  }
  bool subscribe(const std::string& channel, Handler handler) override {
    return inner_.subscribe(channel, std::move(handler));
  }
  int fileno() override { return inner_.fileno(); }
  int handleTimeout(int timeout_ms) override { return inner_.handleTimeout(timeout_ms); }

 private:
  Bus& inner_;
  int sent_ = 0;
};

// Every tile that could not be sent is a publish error of its own; the subscriber gets the map
// with those tiles' cells unseen and knows how many.
TEST(MapPublisher, CountsEveryFailedTileAsAPublishError) {
  MemoryNetwork network;
  auto daemon = network.connect();
  auto subscriber = network.connect();
  FlakyBus flaky(*daemon);
  std::vector<Given> heard;
  MapReceiver* receiver_seen = nullptr;
  MapReceiver receiver(*subscriber, "OCCMAP_MAP", [&](const DecodedMap& map, std::int64_t) {
    heard.push_back({map, receiver_seen->tilesOfMap()});
  });
  receiver_seen = &receiver;
  const MapGeometry geometry{-0.5, -1.5, 0.02, 720, 480};  // 3 x 2 tiles
  const auto names = sceneCameraNames(2);
  MapPublisher publisher(geometry, names, MapEncoding::kRaw, "OCCMAP_MAP", "flaky",
                         MapMessages::kTiles);
  for (int n = 0; n < 4; ++n) {
    MapFrame frame = makeFrame(geometry, names.size(), n, Cells::kRandom);
    EXPECT_FALSE(publisher.publish(flaky, frame)) << "2 of its 6 tiles fail";
  }
  EXPECT_EQ(publisher.errors(), 8u) << "each failed tile counted";
  EXPECT_EQ(publisher.published(), 0u) << "no map went out whole";
  drain(*subscriber);
  receiver.flush();
  ASSERT_EQ(heard.size(), 4u);
  for (const Given& given : heard) {
    EXPECT_EQ(given.tiles.count, 6);
    EXPECT_EQ(given.tiles.missing, 2);
  }
  EXPECT_EQ(receiver.counters().tiles.tiles_lost, 8u);
}

// ---------------------------------------------------------------------------------------------
// The config's transport.tiles

TEST(TransportConfig, TilesIsABooleanOffByDefault) {
  const std::string minimal = "map: {}\ncameras:\n  - name: c0\n    source: sim://room\n";
  EXPECT_FALSE(parseConfig(minimal, "/etc/occmap/a.yaml").transport.tiles);
  EXPECT_TRUE(
      parseConfig(minimal + "transport: {tiles: true}\n", "/etc/occmap/a.yaml").transport.tiles);
  try {
    parseConfig(minimal + "transport: {encoding: raw, tiles: yes}\n", "/etc/occmap/a.yaml");
    ADD_FAILURE() << "tiles: yes was accepted";
  } catch (const InputError& error) {
    EXPECT_EQ(error.line(), 5);
    EXPECT_EQ(error.field(), "transport.tiles");
    const std::string message = error.what();
    EXPECT_EQ(message.rfind("/etc/occmap/a.yaml:5: ", 0), 0u) << message;
    EXPECT_NE(message.find("must be true or false"), std::string::npos) << message;
  }
}

}  // namespace
}  // namespace occmap
