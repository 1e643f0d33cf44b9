#pragma once
// Map frames to and from occmap.map_frame_t, the LCM message occmapd broadcasts
// (lcmtypes/map_frame_t.lcm). The encoder sits on the publisher thread's hot path: after
// construction it allocates nothing. The decoder reads what arrives from the network: it checks
// every length and value before trusting it, and says in words what is wrong with a bad message.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <occmap/map_frame_t.hpp>

#include "core/map_frame.h"
#include "core/map_geometry.h"
#include "transport/zstd_frame.h"

namespace occmap {

// How map_frame_t.data holds the cells; the values are map_frame_t's ENCODING_* constants.
enum class MapEncoding : std::uint8_t {
  kRaw = 0,   // one byte per cell
  kZstd = 1,  // the raw bytes as one zstd frame that declares its content size
};

// "raw" or "zstd" (the config's transport.encoding); nothing for anything else.
std::optional<MapEncoding> parseMapEncoding(std::string_view text);
const char* mapEncodingName(MapEncoding encoding);

// The largest map a decoder accepts, per side. 8192 x 8192 cells are 64 MiB decoded: the most a
// hostile message can make a decoder allocate.
inline constexpr int kMaxMapSide = 8192;

// Encodes MapFrames of one geometry and one camera list into complete LCM messages (fingerprint
// included), ready for LcmBus::publish. Everything is allocated by the constructor: the message
// whose vectors and strings keep their capacity, zstd's compression context in a fixed workspace
// (it cannot grow), and an output buffer of the largest encoded size. One thread at a time.
class MapEncoder {
 public:
  // zstd level: 1 is zstd's fastest regular level (a 512 x 512 map in well under a millisecond).
  static constexpr int kZstdLevel = 1;

  // Throws std::invalid_argument when a side is outside 1..kMaxMapSide or there are more cameras
  // than map_frame_t can count (32767): decoders would refuse such maps.
  MapEncoder(const MapGeometry& geometry, const std::vector<std::string>& camera_names,
             MapEncoding encoding);
  ~MapEncoder();
  MapEncoder(const MapEncoder&) = delete;
  MapEncoder& operator=(const MapEncoder&) = delete;

  // The message of `frame`, valid until the next call. Empty when the frame does not fit this
  // encoder (another width, height or camera count) or compression failed: lastError() says why,
  // and the caller counts it as a publish error. Allocates nothing.
  std::span<const std::uint8_t> encode(const MapFrame& frame);

  // Why the last encode() returned nothing (a fixed text), or "" after a success.
  const char* lastError() const { return last_error_; }
  MapEncoding encoding() const { return encoding_; }
  // The largest message encode() can return (raw or zstd's bound), for sizing receive buffers.
  std::size_t maxMessageSize() const { return output_.size(); }

 private:
  MapGeometry geometry_;
  MapEncoding encoding_;
  occmap::map_frame_t message_{};
  std::vector<std::uint8_t> output_;
  std::optional<ZstdCompressor> zstd_;  // for MapEncoding::kZstd
  const char* last_error_ = "";
};

// One camera's part in a decoded map (map_frame_t.cameras[k]).
struct DecodedCamera {
  std::string name;
  CameraState state = CameraState::kStarting;
  bool used = false;
  std::int64_t sequence = -1;
  std::int64_t capture_utime = 0;
};

// A map_frame_t as received. When `error` is not empty the message was refused and only the
// header fields read before the problem are meaningful.
struct DecodedMap {
  std::string error;
  std::int64_t utime = 0;
  std::int64_t seq = 0;
  MapGeometry geometry;  // width, height, cell_size_m, origin_x_m, origin_y_m
  MapEncoding encoding = MapEncoding::kRaw;
  std::size_t data_size = 0;        // bytes of `data` on the wire
  std::size_t message_size = 0;     // bytes of the whole message
  std::vector<std::uint8_t> cells;  // width * height values: 0 free, 1 occupied, 2 unseen
  std::vector<DecodedCamera> cameras;

  bool ok() const { return error.empty(); }
  // The cells as an OccupancyMap (for pictures); only when ok().
  OccupancyMap toOccupancyMap() const;
};

// Decodes map_frame_t messages of any encoding. Refuses, with a message saying what is wrong:
// another fingerprint (another type or another version of this one), a size that does not add up
// to exactly the bytes received (truncated, trailing bytes, negative or lying counts), a side
// outside 1..kMaxMapSide, a non-finite or non-positive cell size, an unknown encoding, raw data
// that is not width * height bytes, a zstd frame whose declared content size is not width * height
// (checked before decompressing) or that does not decompress to it, a cell value above 2, an
// unknown camera state, a camera name with a NUL inside. Nothing is allocated beyond the received
// size and width * height cells; no exception leaves decode(). Buffers are reused from message to
// message. One thread at a time.
class MapDecoder {
 public:
  MapDecoder();
  ~MapDecoder();
  MapDecoder(const MapDecoder&) = delete;
  MapDecoder& operator=(const MapDecoder&) = delete;

  // The decoded message, valid until the next call.
  const DecodedMap& decode(const void* data, std::size_t size);

 private:
  void decodeChecked(const std::uint8_t* data, std::size_t size);

  ZSTD_DCtx_s* zstd_ = nullptr;
  occmap::map_frame_t message_{};
  DecodedMap result_;
};

}  // namespace occmap
