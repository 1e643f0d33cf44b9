#include "transport/map_tiles.h"

#include <algorithm>
#include <cinttypes>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <new>
#include <stdexcept>
#include <type_traits>

#include <zstd.h>

#include "transport/wire_reader.h"
#include "transport/zstd_frame.h"

namespace occmap {
namespace {

static_assert(static_cast<int>(MapEncoding::kRaw) == occmap::map_tile_t::ENCODING_RAW);
static_assert(static_cast<int>(MapEncoding::kZstd) == occmap::map_tile_t::ENCODING_ZSTD);
static_assert(static_cast<int>(CellState::kFree) == occmap::map_tile_t::FREE);
static_assert(static_cast<int>(CellState::kOccupied) == occmap::map_tile_t::OCCUPIED);
static_assert(static_cast<int>(CellState::kUnseen) == occmap::map_tile_t::UNSEEN);
static_assert(kMaxTileSide * kMaxTileSide <= static_cast<int>(kMaxTileMessageSize) &&
                  (kMaxTileSide + 1) * (kMaxTileSide + 1) > static_cast<int>(kMaxTileMessageSize),
              "kMaxTileSide is the largest raw tile that fits a message");

constexpr int kMaxTileCameras = INT16_MAX;  // map_tile_t.num_cameras is an int16_t

std::string tileHex(std::int64_t value) {
  char text[24];
  std::snprintf(text, sizeof text, "0x%016" PRIx64, static_cast<std::uint64_t>(value));
  return text;
}

std::string tileNumber(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", value);
  return text;
}

template <typename T>
std::string tileNumber(T value) requires std::is_integral_v<T> {
  return std::to_string(value);
}

int tilesAcross(int cells, int side) { return (cells + side - 1) / side; }

}  // namespace

std::string tilesChannel(const std::string& map_channel) { return map_channel + "_TILES"; }

// ---------------------------------------------------------------------------------------------
// MapTileEncoder

MapTileEncoder::MapTileEncoder(const MapGeometry& geometry,
                               const std::vector<std::string>& camera_names, MapEncoding encoding)
    : geometry_(geometry), encoding_(encoding) {
  if (geometry.width < 1 || geometry.width > kMaxMapSide || geometry.height < 1 ||
      geometry.height > kMaxMapSide) {
    throw std::invalid_argument("MapTileEncoder: a map of " + std::to_string(geometry.width) +
                                " x " + std::to_string(geometry.height) +
                                " cells; each side must be 1.." + std::to_string(kMaxMapSide));
  }
  if (camera_names.size() > static_cast<std::size_t>(kMaxTileCameras)) {
    throw std::invalid_argument("MapTileEncoder: " + std::to_string(camera_names.size()) +
                                " cameras; map_tile_t counts at most " +
                                std::to_string(kMaxTileCameras));
  }
  message_.width = geometry.width;
  message_.height = geometry.height;
  message_.num_cameras = static_cast<std::int16_t>(camera_names.size());
  message_.cameras.resize(camera_names.size());
  for (std::size_t k = 0; k < camera_names.size(); ++k) {
    message_.cameras[k].name = camera_names[k];
    message_.cameras[k].sequence = -1;
  }
  // The largest tile whose raw cells fit one message beside the header and the camera list (every
  // tile carries both): 240 x 240 unless the camera list is long.
  message_.data_size = 0;
  const auto overhead = static_cast<std::size_t>(message_.getEncodedSize());
  const std::size_t room = overhead < kMaxTileMessageSize ? kMaxTileMessageSize - overhead : 0;
  side_ = std::min(kPreferredTileSide, static_cast<int>(std::sqrt(static_cast<double>(room))));
  while (side_ > 0 && static_cast<std::size_t>(side_) * static_cast<std::size_t>(side_) > room) {
    --side_;  // sqrt's rounding
  }
  if (side_ < kMinTileSide) {
    throw std::invalid_argument(
        "MapTileEncoder: the camera list takes " + std::to_string(overhead) +
        " bytes of every tile, which leaves no room for a tile of " + std::to_string(kMinTileSide) +
        " x " + std::to_string(kMinTileSide) + " cells in " + std::to_string(kMaxTileMessageSize) +
        " bytes: use fewer cameras or shorter names");
  }
  columns_ = tilesAcross(geometry.width, side_);
  rows_ = tilesAcross(geometry.height, side_);
  message_.tile_side = side_;
  message_.tile_count = columns_ * rows_;
  const std::size_t tile_cells = static_cast<std::size_t>(side_) * static_cast<std::size_t>(side_);
  cells_.resize(tile_cells);
  // `data` keeps its size; data_size says how much of it a message uses. zstd writes into it with
  // room for raw cells only: a tile it cannot shrink fails to compress and goes raw.
  message_.data.resize(tile_cells);
  message_.data_size = static_cast<std::int32_t>(tile_cells);
  output_.resize(static_cast<std::size_t>(message_.getEncodedSize()));
  message_.data_size = 0;
  if (encoding == MapEncoding::kZstd) zstd_.emplace(kZstdLevel, tile_cells, "MapTileEncoder");
}

MapTileEncoder::~MapTileEncoder() = default;

std::span<const std::uint8_t> MapTileEncoder::encode(const MapFrame& frame, int index) {
  const MapGeometry& g = frame.map.geometry;
  if (g.width != geometry_.width || g.height != geometry_.height ||
      frame.map.cells.size() != geometry_.cellCount()) {
    last_error_ = "the map's size is not the encoder's";
    return {};
  }
  if (frame.cameras.size() != message_.cameras.size()) {
    last_error_ = "the map's camera count is not the encoder's";
    return {};
  }
  if (index < 0 || index >= tileCount()) {
    last_error_ = "no tile of that index";
    return {};
  }
  const int first_column = index % columns_ * side_;
  const int first_row = index / columns_ * side_;
  const int tile_width = std::min(side_, g.width - first_column);
  const int tile_height = std::min(side_, g.height - first_row);
  const auto width = static_cast<std::size_t>(tile_width);
  const std::size_t cells = width * static_cast<std::size_t>(tile_height);
  // Raw cells go straight into the message; zstd's source is the tile gathered row by row.
  std::uint8_t* gathered = encoding_ == MapEncoding::kRaw ? message_.data.data() : cells_.data();
  const auto* map_cells = reinterpret_cast<const std::uint8_t*>(frame.map.cells.data());
  for (int r = 0; r < tile_height; ++r) {
    const std::size_t from =
        static_cast<std::size_t>(first_row + r) * static_cast<std::size_t>(g.width) +
        static_cast<std::size_t>(first_column);
    std::memcpy(gathered + static_cast<std::size_t>(r) * width, map_cells + from, width);
  }
  message_.encoding = occmap::map_tile_t::ENCODING_RAW;
  message_.data_size = static_cast<std::int32_t>(cells);
  if (encoding_ == MapEncoding::kZstd) {
    // Room for raw cells only: a tile zstd would not make smaller fails here and goes raw.
    const std::size_t size = zstd_->compress(message_.data.data(), cells, gathered, cells);
    if (size != 0 && size < cells) {
      message_.encoding = occmap::map_tile_t::ENCODING_ZSTD;
      message_.data_size = static_cast<std::int32_t>(size);
    } else {
      std::memcpy(message_.data.data(), gathered, cells);
    }
  }
  message_.utime = frame.utime;
  message_.seq = frame.seq;
  message_.cell_size_m = g.cell_size_m;
  message_.origin_x_m = g.origin_x_m;
  message_.origin_y_m = g.origin_y_m;
  message_.first_column = first_column;
  message_.first_row = first_row;
  message_.tile_width = tile_width;
  message_.tile_height = tile_height;
  message_.tile_index = index;
  for (std::size_t k = 0; k < frame.cameras.size(); ++k) {
    const CameraContribution& in = frame.cameras[k];
    occmap::camera_frame_t& out = message_.cameras[k];
    out.state = static_cast<std::int8_t>(in.state);
    out.used = in.used;
    out.sequence = in.sequence;
    out.capture_utime = in.capture_time_us;
  }
  const int size = message_.encode(output_.data(), 0, static_cast<int>(output_.size()));
  if (size < 0) {
    last_error_ = "LCM's encoder failed";
    return {};
  }
  last_error_ = "";
  return {output_.data(), static_cast<std::size_t>(size)};
}

// ---------------------------------------------------------------------------------------------
// MapTileAssembler

struct MapTileAssembler::Tile {
  std::int64_t utime = 0;
  std::int64_t seq = 0;
  MapGeometry geometry;
  int side = 0;
  int first_column = 0;
  int first_row = 0;
  int width = 0;   // tile_width
  int height = 0;  // tile_height
  int index = 0;
  int count = 0;
  MapEncoding encoding = MapEncoding::kRaw;
  std::size_t data_size = 0;
  const std::uint8_t* cells = nullptr;  // width * height checked cells
  std::size_t cameras_at = 0;           // where num_cameras is in the message
  std::size_t cameras_size = 0;         // bytes from there to the end
};

MapTileAssembler::MapTileAssembler(Handler handler)
    : handler_(std::move(handler)), zstd_(ZSTD_createDCtx()) {
  if (zstd_ == nullptr) throw std::bad_alloc();
  tile_cells_.resize(static_cast<std::size_t>(kMaxTileSide) * kMaxTileSide);
}

MapTileAssembler::~MapTileAssembler() { ZSTD_freeDCtx(zstd_); }

bool MapTileAssembler::take(const void* data, std::size_t size, std::int64_t recv_utime) {
  auto refuse = [this](std::string why) {
    ++counters_.tiles_refused;
    counters_.last_error = std::move(why);
    return false;
  };
  if (data == nullptr) return refuse("no data");
  const auto* bytes = static_cast<const std::uint8_t*>(data);
  Tile tile;
  std::string why;
  try {
    decodeTile(bytes, size, tile, why);
  } catch (const std::exception& e) {
    why = std::string("cannot decode: ") + e.what();
  }
  if (!why.empty()) return refuse(std::move(why));

  const bool same_map = in_progress_ && tile.seq == map_.seq && tile.utime == map_.utime;
  if (same_map) {
    const MapGeometry& g = map_.geometry;
    if (tile.geometry.width != g.width || tile.geometry.height != g.height ||
        tile.geometry.cell_size_m != g.cell_size_m || tile.geometry.origin_x_m != g.origin_x_m ||
        tile.geometry.origin_y_m != g.origin_y_m || tile.side != tile_side_) {
      return refuse("tile " + tileNumber(tile.index) + " of map seq " + tileNumber(tile.seq) +
                    " gives the map another geometry or tile side than its tiles taken before");
    }
    if (tile.cameras_size != camera_section_.size() ||
        std::memcmp(bytes + tile.cameras_at, camera_section_.data(), tile.cameras_size) != 0) {
      return refuse("tile " + tileNumber(tile.index) + " of map seq " + tileNumber(tile.seq) +
                    " gives the map another camera list than its tiles taken before");
    }
    if (received_[static_cast<std::size_t>(tile.index)] != 0) {
      ++counters_.tiles_stale;  // a copy
      return true;
    }
  } else {
    // A tile of the map last given out, or of an older one (lower or equal seq, not newer): late.
    // Anything else is a newer map (a higher seq; or a newer capture with a lower seq: the
    // publisher restarted), which means the map in progress will not be completed.
    const bool has_reference = in_progress_ || given_out_;
    const std::int64_t reference_seq = in_progress_ ? map_.seq : given_seq_;
    const std::int64_t reference_utime = in_progress_ ? map_.utime : given_utime_;
    if (has_reference && tile.seq <= reference_seq && tile.utime <= reference_utime) {
      ++counters_.tiles_stale;
      return true;
    }
    if (in_progress_) giveOut();
    try {
      start(tile, bytes);
    } catch (const std::exception& e) {
      in_progress_ = false;
      return refuse(std::string("cannot hold the map: ") + e.what());
    }
  }

  // Its cells into the map, row by row.
  const auto map_width = static_cast<std::size_t>(map_.geometry.width);
  const auto tile_width = static_cast<std::size_t>(tile.width);
  for (int r = 0; r < tile.height; ++r) {
    std::memcpy(map_.cells.data() + static_cast<std::size_t>(tile.first_row + r) * map_width +
                    static_cast<std::size_t>(tile.first_column),
                tile.cells + static_cast<std::size_t>(r) * tile_width, tile_width);
  }
  received_[static_cast<std::size_t>(tile.index)] = 1;
  ++tiles_received_;
  ++counters_.tiles_taken;
  tiles_.recv_utime = recv_utime;
  if (tile.encoding == MapEncoding::kZstd) map_.encoding = MapEncoding::kZstd;
  map_.data_size += tile.data_size;
  map_.message_size += size;
  if (tiles_received_ == tiles_.count) giveOut();
  return true;
}

void MapTileAssembler::flush() {
  if (in_progress_) giveOut();
}

void MapTileAssembler::start(const Tile& tile, const std::uint8_t* data) {
  in_progress_ = false;
  map_.error.clear();
  map_.utime = tile.utime;
  map_.seq = tile.seq;
  map_.geometry = tile.geometry;
  map_.encoding = tile.encoding;
  map_.data_size = 0;
  map_.message_size = 0;
  // No camera vouches for a cell until its tile has come.
  map_.cells.assign(tile.geometry.cellCount(), static_cast<std::uint8_t>(CellState::kUnseen));
  camera_section_.assign(data + tile.cameras_at, data + tile.cameras_at + tile.cameras_size);
  // The camera list was walked and checked by decodeTile(): read it again, trusting its counts.
  WireReader in(data + tile.cameras_at, tile.cameras_size);
  std::int16_t num_cameras = 0;
  in.read(num_cameras);
  map_.cameras.resize(static_cast<std::size_t>(num_cameras));
  for (DecodedCamera& camera : map_.cameras) {
    const char* name = nullptr;
    std::size_t length = 0;
    std::int8_t state = 0, used = 0;
    in.readString(name, length);
    in.read(state);
    in.read(used);
    in.read(camera.sequence);
    in.read(camera.capture_utime);
    camera.name.assign(name, length);
    camera.state = static_cast<CameraState>(state);
    camera.used = used != 0;
  }
  tile_side_ = tile.side;
  received_.assign(static_cast<std::size_t>(tile.count), 0);
  tiles_ = MapTiles{tile.count, 0, 0};
  tiles_received_ = 0;
  in_progress_ = true;
}

void MapTileAssembler::giveOut() {
  in_progress_ = false;
  tiles_.missing = tiles_.count - tiles_received_;
  if (tiles_.missing == 0) {
    ++counters_.maps_complete;
  } else {
    ++counters_.maps_incomplete;
    counters_.tiles_lost += static_cast<std::uint64_t>(tiles_.missing);
  }
  given_out_ = true;
  given_seq_ = map_.seq;
  given_utime_ = map_.utime;
  if (handler_) handler_(map_, tiles_);
}

void MapTileAssembler::decodeTile(const std::uint8_t* data, std::size_t size, Tile& t,
                                  std::string& why) {
  auto fail = [&why](std::string text) { why = std::move(text); };
  // Made only for a message: a good tile is checked without allocating.
  const auto received = [size] { return std::to_string(size) + " bytes received"; };
  if (size > static_cast<std::size_t>(INT_MAX)) {
    return fail("larger than LCM allows: " + received());
  }
  WireReader in(data, size);
  std::int64_t fingerprint = 0;
  if (!in.read(fingerprint)) {
    return fail("too short for an LCM message (" + received() + "; its fingerprint alone is 8)");
  }
  if (fingerprint != occmap::map_tile_t::getHash()) {
    return fail("not an occmap.map_tile_t: fingerprint " + tileHex(fingerprint) +
                ", map_tile_t's is " + tileHex(occmap::map_tile_t::getHash()) +
                " (another message type on this channel, or another version of map_tile_t)");
  }
  std::int32_t width = 0, height = 0, side = 0, first_column = 0, first_row = 0, tile_width = 0,
               tile_height = 0, index = 0, count = 0, data_size = 0;
  double cell_size = 0, origin_x = 0, origin_y = 0;
  std::int8_t encoding = 0;
  if (!(in.read(t.utime) && in.read(t.seq) && in.read(width) && in.read(height) &&
        in.read(cell_size) && in.read(origin_x) && in.read(origin_y) && in.read(side) &&
        in.read(first_column) && in.read(first_row) && in.read(tile_width) &&
        in.read(tile_height) && in.read(index) && in.read(count) && in.read(encoding) &&
        in.read(data_size))) {
    return fail("truncated: the message ends inside the header (" + received() + ", it needs 89)");
  }
  for (const auto& [name, value] : {std::pair{"width", width}, std::pair{"height", height}}) {
    if (value < 1 || value > kMaxMapSide) {
      return fail(std::string("the map's ") + name + " " + tileNumber(value) + " is outside 1.." +
                  tileNumber(kMaxMapSide));
    }
  }
  if (!std::isfinite(cell_size) || cell_size <= 0) {
    return fail("cell_size_m " + tileNumber(cell_size) + " is not a positive number");
  }
  if (!std::isfinite(origin_x) || !std::isfinite(origin_y)) {
    return fail("the origin (" + tileNumber(origin_x) + ", " + tileNumber(origin_y) +
                ") is not finite");
  }
  t.geometry = MapGeometry{origin_x, origin_y, cell_size, width, height};
  if (side < kMinTileSide || side > kMaxTileSide) {
    return fail("tile_side " + tileNumber(side) + " is outside " + tileNumber(kMinTileSide) + ".." +
                tileNumber(kMaxTileSide));
  }
  const int columns = tilesAcross(width, side), rows = tilesAcross(height, side);
  if (count != columns * rows) {
    return fail("tile_count " + tileNumber(count) + " is not the " + tileNumber(columns) + " x " +
                tileNumber(rows) + " tiles of side " + tileNumber(side) + " that a " +
                tileNumber(width) + " x " + tileNumber(height) + " map is cut into");
  }
  if (index < 0 || index >= count) {
    return fail("tile_index " + tileNumber(index) + " is outside 0.." + tileNumber(count - 1));
  }
  const int expected_column = index % columns * side, expected_row = index / columns * side;
  const int expected_width = std::min(side, width - expected_column);
  const int expected_height = std::min(side, height - expected_row);
  if (first_column != expected_column || first_row != expected_row ||
      tile_width != expected_width || tile_height != expected_height) {
    return fail("tile " + tileNumber(index) + " says it is " + tileNumber(tile_width) + " x " +
                tileNumber(tile_height) + " cells at column " + tileNumber(first_column) +
                ", row " + tileNumber(first_row) + "; in the grid of side " + tileNumber(side) +
                " it is " + tileNumber(expected_width) + " x " + tileNumber(expected_height) +
                " cells at column " + tileNumber(expected_column) + ", row " +
                tileNumber(expected_row));
  }
  t.side = side;
  t.first_column = first_column;
  t.first_row = first_row;
  t.width = tile_width;
  t.height = tile_height;
  t.index = index;
  t.count = count;
  if (encoding != occmap::map_tile_t::ENCODING_RAW &&
      encoding != occmap::map_tile_t::ENCODING_ZSTD) {
    return fail("unknown encoding " + tileNumber(encoding) + " (0 raw, 1 zstd)");
  }
  t.encoding = static_cast<MapEncoding>(encoding);
  if (data_size < 0) return fail("data_size " + tileNumber(data_size) + " is negative");
  const std::size_t cells =
      static_cast<std::size_t>(tile_width) * static_cast<std::size_t>(tile_height);
  if (static_cast<std::size_t>(data_size) > in.remaining()) {
    return fail("truncated: data_size says " + tileNumber(data_size) + " bytes but only " +
                tileNumber(in.remaining()) + " follow (" + received() + ")");
  }
  if (t.encoding == MapEncoding::kRaw && static_cast<std::size_t>(data_size) != cells) {
    return fail("raw data_size " + tileNumber(data_size) +
                " is not tile_width * tile_height = " + tileNumber(cells));
  }
  if (t.encoding == MapEncoding::kZstd && data_size == 0) return fail("the zstd data is empty");
  t.data_size = static_cast<std::size_t>(data_size);
  const std::uint8_t* payload = data + in.position();
  in.skip(t.data_size);
  t.cameras_at = in.position();
  std::int16_t num_cameras = 0;
  if (!in.read(num_cameras)) {
    return fail("truncated: the message ends before num_cameras (" + received() + ")");
  }
  if (num_cameras < 0) return fail("num_cameras " + tileNumber(num_cameras) + " is negative");
  for (int k = 0; k < num_cameras; ++k) {
    const auto which = [k, num_cameras] {
      return "camera " + tileNumber(k) + " of " + tileNumber(num_cameras);
    };
    const char* name = nullptr;
    std::size_t length = 0;
    if (!in.readString(name, length)) {
      return fail(which() + ": its name is not a NUL-terminated string that fits the bytes left " +
                  "(num_cameras too large, truncated, or a NUL inside the name)");
    }
    std::int8_t state = 0, used = 0;
    std::int64_t sequence = 0, capture_utime = 0;
    if (!(in.read(state) && in.read(used) && in.read(sequence) && in.read(capture_utime))) {
      return fail("truncated: the message ends in " + which());
    }
    if (state < 0 || state > occmap::camera_frame_t::STATE_DOWN) {
      return fail(which() + ": unknown state " + tileNumber(state) +
                  " (0 starting, 1 streaming, 2 down)");
    }
    if (used != 0 && used != 1) {
      return fail(which() + ": 'used' is " + tileNumber(used) + ", not a boolean (0 or 1)");
    }
  }
  if (in.remaining() != 0) {
    return fail(tileNumber(in.remaining()) +
                " bytes left over after the message: its counts do not add up to the " +
                received());
  }
  t.cameras_size = size - t.cameras_at;

  // The cells: raw in place, zstd into tile_cells_ (which holds the largest tile there is).
  if (t.encoding == MapEncoding::kRaw) {
    t.cells = payload;
  } else {
    std::string corrupt = zstdFrameProblem(payload, t.data_size, cells, "tile_width * tile_height");
    if (corrupt.empty()) {
      corrupt = decompressZstdFrame(zstd_, payload, t.data_size, tile_cells_.data(), cells);
    }
    if (!corrupt.empty()) return fail(corrupt);
    t.cells = tile_cells_.data();
  }
  const std::uint8_t* end = t.cells + cells;
  const std::uint8_t* bad = std::find_if(t.cells, end, [](std::uint8_t v) {
    return v > static_cast<std::uint8_t>(CellState::kUnseen);
  });
  if (bad != end) {
    const auto at = static_cast<int>(bad - t.cells);
    return fail("tile " + tileNumber(index) + "'s cell (row " +
                tileNumber(first_row + at / tile_width) + ", column " +
                tileNumber(first_column + at % tile_width) + ") is " + tileNumber(*bad) +
                "; cells are 0 free, 1 occupied, 2 unseen");
  }
}

}  // namespace occmap
