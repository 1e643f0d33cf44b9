#pragma once
// Maps larger than one datagram (issue 16): each map cut into tiles, each tile a complete
// occmap.map_tile_t (lcmtypes/map_tile_t.lcm) of at most 61440 bytes whatever its cells, sent on
// the map channel's name + "_TILES". A datagram lost on the way loses one tile, not the map, and
// the subscriber knows which: its cells are unseen in the map it is given, and it is counted.
//
// The encoder sits on the publisher thread's hot path: after construction it allocates nothing.
// The assembler reads what arrives from the network: every length and value is checked before it
// is trusted (as MapDecoder does), a bad tile is refused with a message saying what is wrong, and
// nothing undecodable is ever given out as part of a map.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <occmap/map_tile_t.hpp>

#include "core/map_frame.h"
#include "core/map_geometry.h"
#include "transport/map_codec.h"
#include "transport/zstd_frame.h"

namespace occmap {

// Where tiled maps go: the map channel's name + "_TILES" (OCCMAP_MAP_TILES), one LCM type per
// channel as tracks go on "_TRACKS" and zones on "_ZONES".
std::string tilesChannel(const std::string& map_channel);

// The most bytes one map_tile_t message takes: under LCM's 65499-byte single datagram with room
// for the channel's name, and whatever the cells (a tile zstd would not shrink goes raw).
inline constexpr std::size_t kMaxTileMessageSize = 61440;
// A whole tile's side, as the encoder chooses it: 240 x 240 raw cells (57600 bytes) and the header
// fit kMaxTileMessageSize with room for the camera list; a long camera list makes tiles smaller.
inline constexpr int kPreferredTileSide = 240;
// The tile sides a map_tile_t may have: no smaller (a hostile tile cannot make a map of millions
// of tiles), and no larger than a raw tile that fits kMaxTileMessageSize.
inline constexpr int kMinTileSide = 16;
inline constexpr int kMaxTileSide = 247;  // 247 * 247 = 61009 cells

// Encodes MapFrames of one geometry and one camera list into their tiles' complete LCM messages
// (fingerprint included), ready for Bus::publish. Everything is allocated by the constructor (the
// message whose vectors and strings keep their capacity, zstd's context in a fixed workspace, the
// tile's cells and the output buffer); encode() allocates nothing. One thread at a time.
class MapTileEncoder {
 public:
  static constexpr int kZstdLevel = MapEncoder::kZstdLevel;

  // Throws std::invalid_argument when a side is outside 1..kMaxMapSide, there are more cameras
  // than map_tile_t can count, or the camera list is so long that not even a tile of
  // kMinTileSide would fit kMaxTileMessageSize.
  MapTileEncoder(const MapGeometry& geometry, const std::vector<std::string>& camera_names,
                 MapEncoding encoding);
  ~MapTileEncoder();
  MapTileEncoder(const MapTileEncoder&) = delete;
  MapTileEncoder& operator=(const MapTileEncoder&) = delete;

  // Tiles per map, and a whole tile's side in cells.
  int tileCount() const { return columns_ * rows_; }
  int tileSide() const { return side_; }

  // The message of tile `index` (0 .. tileCount() - 1) of `frame`, valid until the next call: at
  // most kMaxTileMessageSize bytes. Empty when the frame does not fit this encoder (another width,
  // height or camera count), the index is out of range or LCM's encoder failed: lastError() says
  // why, and the caller counts it as a publish error. Allocates nothing.
  std::span<const std::uint8_t> encode(const MapFrame& frame, int index);

  // Why the last encode() returned nothing (a fixed text), or "" after a success.
  const char* lastError() const { return last_error_; }
  MapEncoding encoding() const { return encoding_; }

 private:
  MapGeometry geometry_;
  MapEncoding encoding_;
  int side_ = kPreferredTileSide;
  int columns_ = 1;  // tiles per row of the grid
  int rows_ = 1;     // rows of tiles
  occmap::map_tile_t message_{};
  std::vector<std::uint8_t> cells_;  // one tile's cells, gathered row by row
  std::vector<std::uint8_t> output_;
  std::optional<ZstdCompressor> zstd_;  // for MapEncoding::kZstd
  const char* last_error_ = "";
};

// The tiles of a map the assembler gives out.
struct MapTiles {
  int count = 0;    // tiles the map was cut into (map_tile_t.tile_count); 0 for a whole map_frame_t
  int missing = 0;  // of them, never received: their cells are UNSEEN in the map given out
  std::int64_t recv_utime = 0;  // when the last of its tiles that came was received
};

// What an assembler has seen. A map all of whose tiles were lost is not here: no tile says it
// existed; it shows as a gap in the maps' seq.
struct MapTileCounters {
  std::uint64_t maps_complete = 0;    // maps given out with every tile
  std::uint64_t maps_incomplete = 0;  // maps given out with tiles missing (their cells unseen)
  std::uint64_t tiles_taken = 0;      // tiles that went into a map
  std::uint64_t tiles_lost = 0;       // tiles missing from the maps given out
  std::uint64_t tiles_refused = 0;    // undecodable, or not agreeing with the rest of their map
  // Another copy of a tile already taken, or a tile of a map already given out (or older): left
  // out, no harm done.
  std::uint64_t tiles_stale = 0;
  std::string last_error;  // why the last refused tile was refused
};

// Puts maps together from map_tile_t messages as they arrive: in any order, with copies, with
// tiles lost, with hostile bytes among them. A map is given out (to the handler) when all its tiles
// have come, or when a tile of a newer map shows that it will not be completed (or at flush()):
// then the cells of its missing tiles are UNSEEN (no camera vouches for them here) and
// MapTiles::missing says how many tiles that is. A tile is refused, with a message saying what is
// wrong, when it is not exactly one map_tile_t (fingerprint, a count that does not add up to the
// bytes received, truncated, bytes left over), its map's header is out of range (sides outside
// 1..kMaxMapSide, a cell size that is not a positive number, an origin that is not finite), its
// place is not the one its index has in the grid of tile_side (tile_side outside
// kMinTileSide..kMaxTileSide, a tile_count that is not the grid's), its data is not its cells
// (raw of another size, a zstd frame that does not declare or decompress to exactly them, a cell
// above 2), a camera is malformed, or it disagrees with the tiles of its map taken before (another
// geometry, tile side or camera list). Nothing is allocated beyond the received size, one tile's
// cells and one map's cells (at most kMaxMapSide squared: what a hostile tile can make it
// allocate); no exception leaves take(). One thread at a time; the handler must not call back in.
class MapTileAssembler {
 public:
  // `map` is valid during the call only; it is ok(), its cells are the tiles' and UNSEEN where a
  // tile is missing, its cameras those of its tiles, its encoding zstd when any tile was,
  // data_size and message_size the sums over the tiles taken.
  using Handler = std::function<void(const DecodedMap& map, const MapTiles& tiles)>;

  explicit MapTileAssembler(Handler handler);
  ~MapTileAssembler();
  MapTileAssembler(const MapTileAssembler&) = delete;
  MapTileAssembler& operator=(const MapTileAssembler&) = delete;

  // Takes one message of the tiles channel, received at `recv_utime` (us since the Unix epoch),
  // calling the handler for the maps it ends (an older map left incomplete, then this tile's own
  // map if it is its last tile). False when the tile is refused: lastError() says why.
  bool take(const void* data, std::size_t size, std::int64_t recv_utime = 0);
  // Gives out the map in progress now, its missing tiles unseen (when its stream has stopped).
  void flush();

  const MapTileCounters& counters() const { return counters_; }
  const std::string& lastError() const { return counters_.last_error; }

 private:
  struct Tile;  // one tile decoded and checked (map_tiles.cpp)

  // Checks one message; `why` is left empty when it is a good tile, else says what is wrong.
  void decodeTile(const std::uint8_t* data, std::size_t size, Tile& tile, std::string& why);
  void start(const Tile& tile, const std::uint8_t* data);
  void giveOut();

  Handler handler_;
  ZSTD_DCtx_s* zstd_ = nullptr;
  std::vector<std::uint8_t> tile_cells_;  // the tile being decoded (at most kMaxTileSide squared)
  // The map in progress.
  bool in_progress_ = false;
  DecodedMap map_;
  int tile_side_ = 0;
  std::vector<std::uint8_t> received_;        // per tile index: 1 once taken
  std::vector<std::uint8_t> camera_section_;  // its tiles' camera list as on the wire
  MapTiles tiles_;
  int tiles_received_ = 0;
  // The map last given out: its tiles, and older ones, are stale.
  bool given_out_ = false;
  std::int64_t given_seq_ = 0;
  std::int64_t given_utime_ = 0;
  MapTileCounters counters_;
};

}  // namespace occmap
