#include "transport/map_codec.h"

#include <algorithm>
#include <cinttypes>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <new>
#include <stdexcept>
#include <type_traits>

#include <zstd.h>

#include "transport/wire_reader.h"
#include "transport/zstd_frame.h"

namespace occmap {
namespace {

static_assert(static_cast<int>(MapEncoding::kRaw) == occmap::map_frame_t::ENCODING_RAW);
static_assert(static_cast<int>(MapEncoding::kZstd) == occmap::map_frame_t::ENCODING_ZSTD);
static_assert(static_cast<int>(CellState::kFree) == occmap::map_frame_t::FREE);
static_assert(static_cast<int>(CellState::kOccupied) == occmap::map_frame_t::OCCUPIED);
static_assert(static_cast<int>(CellState::kUnseen) == occmap::map_frame_t::UNSEEN);
static_assert(sizeof(CellState) == 1, "cells are copied to the wire byte for byte");

constexpr int kMaxCameras = INT16_MAX;  // map_frame_t.num_cameras is an int16_t

std::string hex(std::int64_t value) {
  char text[24];
  std::snprintf(text, sizeof text, "0x%016" PRIx64, static_cast<std::uint64_t>(value));
  return text;
}

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", value);
  return text;
}

template <typename T>
std::string number(T value) requires std::is_integral_v<T> {
  return std::to_string(value);
}

}  // namespace

std::optional<MapEncoding> parseMapEncoding(std::string_view text) {
  if (text == "raw") return MapEncoding::kRaw;
  if (text == "zstd") return MapEncoding::kZstd;
  return std::nullopt;
}

const char* mapEncodingName(MapEncoding encoding) {
  return encoding == MapEncoding::kRaw ? "raw" : "zstd";
}

// ---------------------------------------------------------------------------------------------
// MapEncoder

MapEncoder::MapEncoder(const MapGeometry& geometry, const std::vector<std::string>& camera_names,
                       MapEncoding encoding)
    : geometry_(geometry), encoding_(encoding) {
  if (geometry.width < 1 || geometry.width > kMaxMapSide || geometry.height < 1 ||
      geometry.height > kMaxMapSide) {
    throw std::invalid_argument("MapEncoder: a map of " + std::to_string(geometry.width) + " x " +
                                std::to_string(geometry.height) + " cells; each side must be 1.." +
                                std::to_string(kMaxMapSide));
  }
  if (camera_names.size() > static_cast<std::size_t>(kMaxCameras)) {
    throw std::invalid_argument("MapEncoder: " + std::to_string(camera_names.size()) +
                                " cameras; map_frame_t counts at most " +
                                std::to_string(kMaxCameras));
  }
  const std::size_t cells = geometry.cellCount();
  message_.width = geometry.width;
  message_.height = geometry.height;
  message_.encoding = static_cast<std::int8_t>(encoding);
  message_.num_cameras = static_cast<std::int16_t>(camera_names.size());
  message_.cameras.resize(camera_names.size());
  for (std::size_t k = 0; k < camera_names.size(); ++k) {
    message_.cameras[k].name = camera_names[k];
    message_.cameras[k].sequence = -1;
  }
  // `data` keeps its size; data_size says how much of it a message uses.
  std::size_t data_capacity = cells;
  if (encoding == MapEncoding::kZstd) {
    data_capacity = ZSTD_compressBound(cells);
    zstd_.emplace(kZstdLevel, cells, "MapEncoder");
  }
  message_.data.resize(data_capacity);
  message_.data_size = static_cast<std::int32_t>(data_capacity);
  output_.resize(static_cast<std::size_t>(message_.getEncodedSize()));
  message_.data_size = 0;
}

MapEncoder::~MapEncoder() = default;

std::span<const std::uint8_t> MapEncoder::encode(const MapFrame& frame) {
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
  message_.utime = frame.utime;
  message_.seq = frame.seq;
  message_.cell_size_m = g.cell_size_m;
  message_.origin_x_m = g.origin_x_m;
  message_.origin_y_m = g.origin_y_m;
  const std::size_t cells = geometry_.cellCount();
  if (encoding_ == MapEncoding::kRaw) {
    std::memcpy(message_.data.data(), frame.map.cells.data(), cells);
    message_.data_size = static_cast<std::int32_t>(cells);
  } else {
    const std::size_t size = zstd_->compress(
        message_.data.data(), message_.data.size(),
        reinterpret_cast<const std::uint8_t*>(frame.map.cells.data()), cells, &last_error_);
    if (size == 0) return {};
    message_.data_size = static_cast<std::int32_t>(size);
  }
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
// MapDecoder

OccupancyMap DecodedMap::toOccupancyMap() const {
  OccupancyMap map(geometry);
  const std::size_t n = std::min(cells.size(), map.cells.size());
  for (std::size_t i = 0; i < n; ++i) map.cells[i] = static_cast<CellState>(cells[i]);
  return map;
}

MapDecoder::MapDecoder() : zstd_(ZSTD_createDCtx()) {
  if (zstd_ == nullptr) throw std::bad_alloc();
}

MapDecoder::~MapDecoder() { ZSTD_freeDCtx(zstd_); }

const DecodedMap& MapDecoder::decode(const void* data, std::size_t size) {
  DecodedMap& r = result_;
  r.error.clear();
  r.utime = 0;
  r.seq = 0;
  r.geometry = MapGeometry{0, 0, 0, 0, 0};
  r.encoding = MapEncoding::kRaw;
  r.data_size = 0;
  r.message_size = size;
  r.cells.clear();
  r.cameras.clear();
  try {
    if (data == nullptr && size > 0) {
      r.error = "no data";
    } else {
      decodeChecked(static_cast<const std::uint8_t*>(data), size);
    }
  } catch (const std::exception& e) {
    r.error = std::string("cannot decode: ") + e.what();
  }
  if (!r.ok()) {
    r.cells.clear();
    r.cameras.clear();
  }
  return r;
}

void MapDecoder::decodeChecked(const std::uint8_t* data, std::size_t size) {
  DecodedMap& r = result_;
  auto fail = [&r](std::string why) { r.error = std::move(why); };
  const std::string received = std::to_string(size) + " bytes received";
  if (size > static_cast<std::size_t>(INT_MAX)) return fail("larger than LCM allows: " + received);

  // Walk the whole message with every count checked against the bytes received before anything
  // trusts a count: LCM's generated decoder sizes its vectors from them.
  WireReader in(data, size);
  std::int64_t fingerprint = 0;
  if (!in.read(fingerprint)) {
    return fail("too short for an LCM message (" + received + "; its fingerprint alone is 8)");
  }
  if (fingerprint != occmap::map_frame_t::getHash()) {
    return fail("not an occmap.map_frame_t: fingerprint " + hex(fingerprint) +
                ", map_frame_t's is " + hex(occmap::map_frame_t::getHash()) +
                " (another message type on this channel, or another version of map_frame_t)");
  }
  std::int64_t utime = 0, seq = 0;
  std::int32_t width = 0, height = 0, data_size = 0;
  double cell_size = 0, origin_x = 0, origin_y = 0;
  std::int8_t encoding = 0;
  if (!(in.read(utime) && in.read(seq) && in.read(width) && in.read(height) && in.read(cell_size) &&
        in.read(origin_x) && in.read(origin_y) && in.read(encoding) && in.read(data_size))) {
    return fail("truncated: the message ends inside the header (" + received + ", it needs 61)");
  }
  r.utime = utime;
  r.seq = seq;
  r.geometry = MapGeometry{origin_x, origin_y, cell_size, width, height};
  r.data_size = data_size < 0 ? 0 : static_cast<std::size_t>(data_size);
  for (const auto& [name, value] : {std::pair{"width", width}, std::pair{"height", height}}) {
    if (value < 1 || value > kMaxMapSide) {
      return fail(std::string(name) + " " + number(value) + " is outside 1.." +
                  number(kMaxMapSide));
    }
  }
  if (!std::isfinite(cell_size) || cell_size <= 0) {
    return fail("cell_size_m " + number(cell_size) + " is not a positive number");
  }
  if (!std::isfinite(origin_x) || !std::isfinite(origin_y)) {
    return fail("the origin (" + number(origin_x) + ", " + number(origin_y) + ") is not finite");
  }
  if (encoding != occmap::map_frame_t::ENCODING_RAW &&
      encoding != occmap::map_frame_t::ENCODING_ZSTD) {
    return fail("unknown encoding " + number(encoding) + " (0 raw, 1 zstd)");
  }
  r.encoding = static_cast<MapEncoding>(encoding);
  if (data_size < 0) return fail("data_size " + number(data_size) + " is negative");
  const std::size_t cells = r.geometry.cellCount();
  if (static_cast<std::size_t>(data_size) > in.remaining()) {
    return fail("truncated: data_size says " + number(data_size) + " bytes but only " +
                number(in.remaining()) + " follow (" + received + ")");
  }
  if (r.encoding == MapEncoding::kRaw && static_cast<std::size_t>(data_size) != cells) {
    return fail("raw data_size " + number(data_size) + " is not width * height = " + number(cells));
  }
  if (r.encoding == MapEncoding::kZstd && data_size == 0) return fail("the zstd data is empty");
  in.skip(static_cast<std::size_t>(data_size));
  std::int16_t num_cameras = 0;
  if (!in.read(num_cameras)) {
    return fail("truncated: the message ends before num_cameras (" + received + ")");
  }
  if (num_cameras < 0) return fail("num_cameras " + number(num_cameras) + " is negative");
  for (int k = 0; k < num_cameras; ++k) {
    const std::string which = "camera " + number(k) + " of " + number(num_cameras);
    std::int32_t name_size = 0;  // LCM counts the terminating NUL
    if (!in.read(name_size)) return fail("truncated: the message ends in " + which);
    if (name_size < 1 || static_cast<std::size_t>(name_size) > in.remaining()) {
      return fail(which + ": a name of " + number(name_size) + " bytes does not fit the " +
                  number(in.remaining()) + " bytes left (num_cameras too large, or truncated)");
    }
    if (data[in.position() + static_cast<std::size_t>(name_size) - 1] != 0) {
      return fail(which + ": its name does not end in NUL");
    }
    // Every LCM encoder stops a string at its first NUL, so one inside is no name anyone sent (and
    // C subscribers would read another name than C++ and Python ones).
    if (std::memchr(data + in.position(), 0, static_cast<std::size_t>(name_size) - 1) != nullptr) {
      return fail(which + ": its name holds a NUL before its end");
    }
    in.skip(static_cast<std::size_t>(name_size));
    std::int8_t state = 0, used = 0;
    std::int64_t sequence = 0, capture_utime = 0;
    if (!(in.read(state) && in.read(used) && in.read(sequence) && in.read(capture_utime))) {
      return fail("truncated: the message ends in " + which);
    }
    if (state < 0 || state > occmap::camera_frame_t::STATE_DOWN) {
      return fail(which + ": unknown state " + number(state) +
                  " (0 starting, 1 streaming, 2 down)");
    }
    if (used != 0 && used != 1) {
      return fail(which + ": 'used' is " + number(used) + ", not a boolean (0 or 1)");
    }
  }
  if (in.remaining() != 0) {
    return fail(number(in.remaining()) + " bytes left over after the message: its counts do not " +
                "add up to the " + received);
  }

  // Every count agrees with `size`, so LCM's decoder allocates no more than the message holds.
  const int consumed = message_.decode(data, 0, static_cast<int>(size));
  if (consumed != static_cast<int>(size)) {
    return fail("LCM's decoder took " + number(consumed) + " of the " + received);
  }
  const std::uint8_t* payload = message_.data.data();
  if (r.encoding == MapEncoding::kRaw) {
    r.cells.assign(payload, payload + cells);
  } else {
    const auto compressed = static_cast<std::size_t>(data_size);
    std::string why = zstdFrameProblem(payload, compressed, cells, "width * height");
    if (!why.empty()) return fail(why);
    r.cells.resize(cells);  // only once the frame is known to hold that many
    why = decompressZstdFrame(zstd_, payload, compressed, r.cells.data(), cells);
    if (!why.empty()) return fail(why);
  }
  const auto bad = std::find_if(r.cells.begin(), r.cells.end(), [](std::uint8_t v) {
    return v > static_cast<std::uint8_t>(CellState::kUnseen);
  });
  if (bad != r.cells.end()) {
    const auto at = static_cast<int>(bad - r.cells.begin());
    return fail("cell (row " + number(at / width) + ", column " + number(at % width) + ") is " +
                number(*bad) + "; cells are 0 free, 1 occupied, 2 unseen");
  }
  r.cameras.resize(message_.cameras.size());
  for (std::size_t k = 0; k < message_.cameras.size(); ++k) {
    const occmap::camera_frame_t& in_camera = message_.cameras[k];
    DecodedCamera& out = r.cameras[k];
    out.name = in_camera.name;
    out.state = static_cast<CameraState>(in_camera.state);
    out.used = in_camera.used;
    out.sequence = in_camera.sequence;
    out.capture_utime = in_camera.capture_utime;
  }
}

}  // namespace occmap
