// map_tile: map_tile_t tiles as `occmap view` and the merge node read them: MapReceiver
// (transport/map_receiver.h), whose MapTileAssembler (transport/map_tiles.h) puts maps together
// from the tiles channel, with whole map_frame_t maps on the map channel beside them. Anyone on the
// network segment can publish on either. One input is several messages (fuzz/map_tile_input.h),
// so that the assembler sees tiles of several maps, out of order, copied, lost and late.
//
// Every map given out is checked against its tiles as read without the assembler (LCM's generated
// decoder and zstd's one-shot decompression, on tiles the assembler accepted): its cells are its
// tiles' cells and unseen where a tile never came, `missing` counts exactly those, its header and
// cameras are its tiles'. A refused tile, a copy or a late tile gives out nothing; the counters add
// up to what was handed over.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <occmap/map_tile_t.hpp>
#include <zstd.h>

#include "fuzz/fuzz_target.h"
#include "fuzz/map_tile_input.h"
#include "transport/bus.h"
#include "transport/map_codec.h"
#include "transport/map_receiver.h"
#include "transport/map_tiles.h"

namespace occmap::fuzz {
namespace {

// A Bus that hands each message to the receiver's handlers at once, in the caller's thread.
class ReplayBus final : public Bus {
 public:
  bool publish(const std::string&, std::span<const std::uint8_t>) override { return false; }
  bool subscribe(const std::string& channel, Handler handler) override {
    handlers_.emplace_back(channel, std::move(handler));
    return true;
  }
  int fileno() override { return -1; }
  int handleTimeout(int) override { return 0; }

  void deliver(const std::string& channel, Input message, std::int64_t recv_utime) {
    for (const auto& [subscribed, handler] : handlers_) {
      if (subscribed == channel) handler(message.data(), message.size(), recv_utime);
    }
  }

 private:
  std::vector<std::pair<std::string, Handler>> handlers_;
};

// The map a tile says it belongs to: its (seq, utime).
using MapKey = std::pair<std::int64_t, std::int64_t>;

// Read from the header of a tile message (utime at byte 8, seq at byte 16); nothing when it is
// shorter than that.
std::optional<MapKey> mapKeyOf(Input message) {
  if (message.size() < 24) return std::nullopt;
  const auto field = [message](std::size_t at) {
    std::uint64_t bits = 0;
    for (std::size_t i = 0; i < 8; ++i) bits = bits << 8 | message[at + i];
    return static_cast<std::int64_t>(bits);
  };
  return MapKey{field(16), field(8)};
}

// A tile the assembler accepted, read without it: LCM's generated decoder (which trusts the counts,
// safe only once the assembler's walk has found them in agreement with the size) and zstd's
// one-shot decompression.
struct ReadTile {
  occmap::map_tile_t message;
  std::vector<std::uint8_t> cells;  // tile_width * tile_height, row by row
  std::size_t size = 0;             // of the whole message
  std::int64_t recv_utime = 0;
};

ReadTile readAcceptedTile(Input bytes, std::int64_t recv_utime) {
  ReadTile tile;
  tile.size = bytes.size();
  tile.recv_utime = recv_utime;
  occmap::map_tile_t& m = tile.message;
  require(
      m.decode(bytes.data(), 0, static_cast<int>(bytes.size())) == static_cast<int>(bytes.size()),
      "an accepted tile is one whole map_tile_t, as LCM's decoder reads it");
  std::vector<std::uint8_t> again(static_cast<std::size_t>(m.getEncodedSize()));
  require(
      m.encode(again.data(), 0, static_cast<int>(again.size())) == static_cast<int>(again.size()) &&
          std::equal(again.begin(), again.end(), bytes.begin(), bytes.end()),
      "an accepted tile encodes back to the bytes received");
  require(m.tile_width >= 1 && m.tile_width <= m.tile_side && m.tile_height >= 1 &&
              m.tile_height <= m.tile_side,
          "an accepted tile is 1..tile_side cells a side");
  const std::size_t cells =
      static_cast<std::size_t>(m.tile_width) * static_cast<std::size_t>(m.tile_height);
  if (m.encoding == occmap::map_tile_t::ENCODING_RAW) {
    tile.cells = m.data;
    require(tile.cells.size() == cells,
            "an accepted raw tile holds tile_width * tile_height cells");
  } else {
    require(m.encoding == occmap::map_tile_t::ENCODING_ZSTD,
            "an accepted tile's encoding is raw or zstd");
    tile.cells.resize(cells);
    const std::size_t size =
        ZSTD_decompress(tile.cells.data(), cells, m.data.data(), m.data.size());
    require(!ZSTD_isError(size) && size == cells,
            "an accepted zstd tile decompresses to tile_width * tile_height cells");
  }
  return tile;
}

bool sameCamera(const occmap::camera_frame_t& a, const occmap::camera_frame_t& b) {
  return a.name == b.name && a.state == b.state && a.used == b.used && a.sequence == b.sequence &&
         a.capture_utime == b.capture_utime;
}

// What every map given out holds to, whole or put together from tiles.
void checkGivenMap(const DecodedMap& map) {
  const MapGeometry& g = map.geometry;
  require(map.ok(), "a map given out is ok()");
  require(g.width >= 1 && g.width <= kMaxMapSide && g.height >= 1 && g.height <= kMaxMapSide,
          "a map given out is 1..8192 cells a side");
  require(std::isfinite(g.cell_size_m) && g.cell_size_m > 0, "a map given out has a cell size > 0");
  require(std::isfinite(g.origin_x_m) && std::isfinite(g.origin_y_m),
          "a map given out has a finite origin");
  require(map.cells.size() == g.cellCount(), "a map given out has width * height cells");
  require(std::all_of(map.cells.begin(), map.cells.end(), [](std::uint8_t v) { return v <= 2; }),
          "a map given out has cells 0 free, 1 occupied or 2 unseen");
  for (const DecodedCamera& camera : map.cameras) {
    require(static_cast<int>(camera.state) <= 2, "a map given out has camera states 0, 1 or 2");
  }
}

// Hands messages to a MapReceiver and keeps, beside it, the tiles taken into the map in progress,
// so that each map given out can be checked against its tiles.
class Replay {
 public:
  Replay()
      : receiver_(bus_, "OCCMAP_MAP", [this](const DecodedMap& map, std::int64_t recv_utime) {
          onMap(map, recv_utime);
        }) {
    require(receiver_.subscribed(), "a MapReceiver subscribes to both channels");
  }

  void tile(Input message, std::int64_t recv_utime);
  void wholeMap(Input message, std::int64_t recv_utime);
  void flush();
  void checkCounters() const;
  bool refusedAny() const { return refused_tiles_ + undecodable_maps_ != 0; }

 private:
  enum class Doing { kNothing, kTile, kWholeMap, kFlush };

  void onMap(const DecodedMap& map, std::int64_t recv_utime);
  void checkTiledMap(const DecodedMap& map, const MapTiles& tiles);

  ReplayBus bus_;
  MapReceiver receiver_;

  // What is being handed over.
  Doing doing_ = Doing::kNothing;
  Input message_;
  std::int64_t current_recv_utime_ = 0;
  int given_now_ = 0;                     // maps given out while it is
  std::optional<ReadTile> current_tile_;  // the tile being taken, once it went into a map given out

  std::vector<ReadTile> in_progress_;  // the tiles taken into the map in progress, in order
  std::optional<MapKey> given_;        // the map last given out

  std::uint64_t whole_maps_ = 0, undecodable_maps_ = 0;
  std::uint64_t complete_ = 0, incomplete_ = 0, tiles_lost_ = 0, tiles_given_ = 0;
  std::uint64_t refused_tiles_ = 0, stale_tiles_ = 0;
};

void Replay::onMap(const DecodedMap& map, std::int64_t recv_utime) {
  const MapTiles& tiles = receiver_.tilesOfMap();
  ++given_now_;
  checkGivenMap(map);
  if (doing_ == Doing::kWholeMap) {
    require(tiles.count == 0 && tiles.missing == 0 && tiles.recv_utime == recv_utime &&
                recv_utime == current_recv_utime_,
            "a whole map_frame_t is given out as it came, with no tiles");
    ++whole_maps_;
    return;
  }
  require(doing_ == Doing::kTile || doing_ == Doing::kFlush,
          "a tiled map is given out only while a tile is taken, or at flush()");
  require(tiles.count >= 1 && tiles.missing >= 0 && tiles.missing < tiles.count,
          "a tiled map given out has 1 to tile_count of its tiles: 0 <= missing < count");
  require(recv_utime == tiles.recv_utime, "the handler is given the tiles' recv_utime");
  checkTiledMap(map, tiles);
}

void Replay::checkTiledMap(const DecodedMap& map, const MapTiles& tiles) {
  // Its tiles: those taken since it began, and the tile being taken when it is this map's (the
  // assembler gives a map out before it takes a tile of a newer one, and after its last tile).
  std::vector<const ReadTile*> its;
  for (const ReadTile& tile : in_progress_) its.push_back(&tile);
  if (doing_ == Doing::kTile && mapKeyOf(message_) == MapKey{map.seq, map.utime}) {
    current_tile_ = readAcceptedTile(message_, current_recv_utime_);
    its.push_back(&*current_tile_);
  }
  require(!its.empty() && its.size() == static_cast<std::size_t>(tiles.count - tiles.missing),
          "a tiled map's missing tiles are those of its tile_count that never came");

  // A map whose tiles come again after it was given out is not given out again.
  require(!given_ || !(map.seq <= given_->first && map.utime <= given_->second),
          "each tiled map given out is newer than the one before (a higher seq or a newer "
          "capture): none is given out twice");

  const MapGeometry& g = map.geometry;
  const occmap::map_tile_t& first = its.front()->message;
  const int side = first.tile_side;
  require(side >= kMinTileSide && side <= kMaxTileSide, "a tiled map's tile side is 16..247");
  const int columns = (g.width + side - 1) / side, rows = (g.height + side - 1) / side;
  require(tiles.count == columns * rows, "a tiled map's tile_count is its grid's");
  std::vector<std::uint8_t> came(static_cast<std::size_t>(tiles.count), 0);
  const auto map_width = static_cast<std::size_t>(g.width);
  bool any_zstd = false;
  std::size_t data_size = 0, message_size = 0;
  for (const ReadTile* tile : its) {
    const occmap::map_tile_t& m = tile->message;
    require(m.seq == map.seq && m.utime == map.utime,
            "a tiled map is given out with its tiles' seq and utime");
    require(MapGeometry{m.origin_x_m, m.origin_y_m, m.cell_size_m, m.width, m.height} == g,
            "a tiled map is given out with its tiles' geometry");
    require(m.tile_side == side && m.tile_count == tiles.count,
            "the tiles of a map agree on its grid");
    require(std::equal(m.cameras.begin(), m.cameras.end(), first.cameras.begin(),
                       first.cameras.end(), sameCamera),
            "the tiles of a map agree on its cameras");
    require(m.tile_index >= 0 && m.tile_index < tiles.count &&
                came[static_cast<std::size_t>(m.tile_index)] == 0,
            "each tile of a map goes into it once");
    came[static_cast<std::size_t>(m.tile_index)] = 1;
    require(m.first_column == m.tile_index % columns * side &&
                m.first_row == m.tile_index / columns * side &&
                m.tile_width == std::min(side, g.width - m.first_column) &&
                m.tile_height == std::min(side, g.height - m.first_row),
            "a tile taken lies where its index puts it in the grid");
    const auto width = static_cast<std::size_t>(m.tile_width);
    for (int r = 0; r < m.tile_height; ++r) {
      const auto from = tile->cells.begin() + static_cast<std::ptrdiff_t>(width) * r;
      const auto at =
          map.cells.begin() +
          static_cast<std::ptrdiff_t>(static_cast<std::size_t>(m.first_row + r) * map_width +
                                      static_cast<std::size_t>(m.first_column));
      require(std::equal(from, from + static_cast<std::ptrdiff_t>(width), at),
              "a tiled map's cells are its tiles' cells");
    }
    any_zstd = any_zstd || m.encoding == occmap::map_tile_t::ENCODING_ZSTD;
    data_size += static_cast<std::size_t>(m.data_size);
    message_size += tile->size;
  }
  require(map.encoding == (any_zstd ? MapEncoding::kZstd : MapEncoding::kRaw),
          "a tiled map's encoding is zstd when any of its tiles was, else raw");
  require(map.data_size == data_size && map.message_size == message_size,
          "a tiled map's data_size and message_size are the sums over its tiles");
  require(tiles.recv_utime == its.back()->recv_utime,
          "a tiled map's recv_utime is when the last of its tiles came");
  require(
      std::equal(map.cameras.begin(), map.cameras.end(), first.cameras.begin(), first.cameras.end(),
                 [](const DecodedCamera& a, const occmap::camera_frame_t& b) {
                   return a.name == b.name && static_cast<int>(a.state) == b.state &&
                          a.used == b.used && a.sequence == b.sequence &&
                          a.capture_utime == b.capture_utime;
                 }),
      "a tiled map's cameras are its tiles'");
  // No camera vouches for the cells of a tile that never came.
  for (int index = 0; index < tiles.count; ++index) {
    if (came[static_cast<std::size_t>(index)] != 0) continue;
    const int column = index % columns * side, row = index / columns * side;
    const int width = std::min(side, g.width - column), height = std::min(side, g.height - row);
    for (int r = row; r < row + height; ++r) {
      const auto at =
          map.cells.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(r) * map_width +
                                                          static_cast<std::size_t>(column));
      require(std::all_of(at, at + width,
                          [](std::uint8_t v) { return v == static_cast<int>(CellState::kUnseen); }),
              "the cells of a tile that never came are unseen");
    }
  }

  ++(tiles.missing == 0 ? complete_ : incomplete_);
  tiles_lost_ += static_cast<std::uint64_t>(tiles.missing);
  tiles_given_ += its.size();
  in_progress_.clear();
  given_ = MapKey{map.seq, map.utime};
}

void Replay::tile(Input message, std::int64_t recv_utime) {
  const MapReceiverCounters before = receiver_.counters();
  doing_ = Doing::kTile;
  message_ = message;
  current_recv_utime_ = recv_utime;
  given_now_ = 0;
  current_tile_.reset();
  bus_.deliver(receiver_.tileChannel(), message, recv_utime);
  doing_ = Doing::kNothing;
  const MapReceiverCounters after = receiver_.counters();
  const std::uint64_t refused = after.tiles.tiles_refused - before.tiles.tiles_refused;
  const std::uint64_t taken = after.tiles.tiles_taken - before.tiles.tiles_taken;
  const std::uint64_t stale = after.tiles.tiles_stale - before.tiles.tiles_stale;
  require(refused + taken + stale == 1,
          "each tile is either taken, left out (a copy, or late) or refused");
  if (refused != 0) {
    ++refused_tiles_;
    require(given_now_ == 0, "a refused tile gives out no map");
    require(!after.tiles.last_error.empty() &&
                after.last_error == receiver_.tileChannel() + ": " + after.tiles.last_error,
            "a refused tile says why, on its channel");
    return;
  }
  ReadTile read = current_tile_ ? std::move(*current_tile_) : readAcceptedTile(message, recv_utime);
  const occmap::map_tile_t& m = read.message;
  const MapKey key{m.seq, m.utime};
  if (stale != 0) {
    ++stale_tiles_;
    require(given_now_ == 0, "a tile left out gives out no map");
    // The assembler's reference: the map in progress, else the map last given out.
    const std::optional<MapKey> reference =
        in_progress_.empty() ? given_
                             : std::optional<MapKey>(MapKey{in_progress_.front().message.seq,
                                                            in_progress_.front().message.utime});
    const bool copy =
        !in_progress_.empty() && key == *reference &&
        std::any_of(in_progress_.begin(), in_progress_.end(),
                    [&m](const ReadTile& t) { return t.message.tile_index == m.tile_index; });
    const bool late = reference && key.first <= reference->first && key.second <= reference->second;
    require(copy || late,
            "a tile left out is a copy of one taken, or of the map last given out or older");
    return;
  }
  // Taken: into the map in progress, or it began a new one after the old one was given out, or it
  // completed its map (then it was checked with it).
  if (!current_tile_) {
    require(in_progress_.empty() ||
                key == MapKey{in_progress_.front().message.seq, in_progress_.front().message.utime},
            "a tile of another map is taken only after the map in progress is given out");
    in_progress_.push_back(std::move(read));
  }
}

void Replay::wholeMap(Input message, std::int64_t recv_utime) {
  const MapReceiverCounters before = receiver_.counters();
  doing_ = Doing::kWholeMap;
  current_recv_utime_ = recv_utime;
  given_now_ = 0;
  bus_.deliver(receiver_.mapChannel(), message, recv_utime);
  doing_ = Doing::kNothing;
  const MapReceiverCounters after = receiver_.counters();
  if (after.undecodable != before.undecodable) {
    ++undecodable_maps_;
    require(given_now_ == 0 && after.undecodable == before.undecodable + 1,
            "a refused map_frame_t gives out no map and is counted once");
    require(after.last_error.size() > receiver_.mapChannel().size() + 2 &&
                after.last_error.starts_with(receiver_.mapChannel() + ": "),
            "a refused map_frame_t says why, on its channel");
  } else {
    require(given_now_ == 1 && after.whole_maps == before.whole_maps + 1,
            "an accepted map_frame_t is given out once");
  }
  const MapTileCounters& a = after.tiles;
  const MapTileCounters& b = before.tiles;
  require(a.maps_complete == b.maps_complete && a.maps_incomplete == b.maps_incomplete &&
              a.tiles_taken == b.tiles_taken && a.tiles_lost == b.tiles_lost &&
              a.tiles_refused == b.tiles_refused && a.tiles_stale == b.tiles_stale,
          "a message on the map channel leaves the tiles alone");
}

void Replay::flush() {
  const bool in_progress = !in_progress_.empty();
  doing_ = Doing::kFlush;
  given_now_ = 0;
  receiver_.flush();
  doing_ = Doing::kNothing;
  require(given_now_ == (in_progress ? 1 : 0) && in_progress_.empty(),
          "flush() gives out the map in progress, and nothing when there is none");
}

void Replay::checkCounters() const {
  const MapReceiverCounters c = receiver_.counters();
  require(c.maps == whole_maps_ + complete_ + incomplete_ && c.whole_maps == whole_maps_ &&
              c.undecodable == undecodable_maps_,
          "the receiver counts every map given out and every map_frame_t refused");
  const MapTileCounters& t = c.tiles;
  require(t.maps_complete == complete_ && t.maps_incomplete == incomplete_ &&
              t.tiles_lost == tiles_lost_ && t.tiles_taken == tiles_given_ + in_progress_.size() &&
              t.tiles_refused == refused_tiles_ && t.tiles_stale == stale_tiles_,
          "the tile counters add up to the maps given out and the tiles handed over");
}

}  // namespace

bool fuzzMapTile(Input input) {
  bool whole = false;
  const std::vector<TileInputMessage> messages = splitTileInput(input, whole);
  Replay replay;
  std::int64_t recv_utime = 1'700'000'000'000'000;
  for (const TileInputMessage& message : messages) {
    recv_utime += 1000;
    if ((message.header & kOnMapChannel) != 0) {
      replay.wholeMap(message.bytes, recv_utime);
    } else {
      replay.tile(message.bytes, recv_utime);
    }
    if ((message.header & kFlushAfter) != 0) replay.flush();
    replay.checkCounters();
  }
  // The stream stops: the map in progress comes out, and then nothing more.
  replay.flush();
  replay.flush();
  replay.checkCounters();
  return whole && !messages.empty() && !replay.refusedAny();
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzMapTile)
