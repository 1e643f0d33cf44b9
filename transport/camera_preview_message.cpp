#include "transport/camera_preview_message.h"

#include <algorithm>
#include <climits>
#include <new>
#include <stdexcept>

#include <occmap/camera_frame_t.hpp>
#include <occmap/camera_preview_request_t.hpp>
#include <zstd.h>

#include "transport/wire_reader.h"
#include "transport/zstd_frame.h"

namespace occmap {
namespace {

// Coverage is compressed once per camera when the daemon starts: a strong level costs nothing
// later, and every preview carries the bytes it saves.
constexpr int kCoverageZstdLevel = 12;

// Fields of the given types, in order; false as soon as one does not fit. (Named apart from the
// other decoders' helpers: the folder is built as one unit.)
template <typename... T>
bool skipPreviewFields(WireReader& in) {
  const auto skip = [&in](auto ignored) { return in.read(ignored); };
  return (skip(T{}) && ...);
}

// A byte array: its int32 count (already read into `count`) against what is left.
bool skipPreviewBytes(WireReader& in, std::int32_t count) {
  return count >= 0 && in.skip(static_cast<std::size_t>(count));
}

bool skipPreviewString(WireReader& in) {
  const char* text = nullptr;
  std::size_t length = 0;
  return in.readString(text, length);
}

// Why the bytes are not one camera_preview_t, or "" when every count agrees with the size (in the
// order of lcmtypes/camera_preview_t.lcm).
const char* previewLayoutError(const std::uint8_t* data, std::size_t size) {
  WireReader in(data, size);
  std::int64_t fingerprint = 0;
  if (!in.read(fingerprint)) return "too short for an LCM message";
  if (fingerprint != occmap::camera_preview_t::getHash()) {
    return "not an occmap.camera_preview_t (fingerprint)";
  }
  if (!skipPreviewFields<std::int64_t, std::int64_t>(in)) return "truncated in utime or sequence";
  if (!skipPreviewString(in) || !skipPreviewString(in)) {
    return "hostname or camera is not a string that fits";
  }
  // state, stream_width, stream_height, width, height, scale.
  if (!skipPreviewFields<std::int8_t, std::int32_t, std::int32_t, std::int32_t, std::int32_t,
                         std::int32_t>(in)) {
    return "truncated in the preview's sizes";
  }
  std::int32_t count = 0;
  if (!in.read(count)) return "truncated before jpeg_size";
  if (count < 0) return "jpeg_size is negative";
  if (!skipPreviewBytes(in, count)) return "jpeg_size is more than the bytes received";
  if (!in.read(count)) return "truncated before changed_size";
  if (count < 0) return "changed_size is negative";
  if (!skipPreviewBytes(in, count)) return "changed_size is more than the bytes received";
  if (!skipPreviewFields<std::int32_t, std::int32_t>(in)) return "truncated in the map's size";
  if (!in.read(count)) return "truncated before coverage_size";
  if (count < 0) return "coverage_size is negative";
  if (!skipPreviewBytes(in, count)) return "coverage_size is more than the bytes received";
  if (in.remaining() != 0) return "bytes left over: the counts do not add up to the size";
  return "";
}

// The figures of a message whose layout is sound: what the fields say of each other. The fields
// are read again where they lie (the layout walk has checked that they do).
const char* previewFiguresError(const std::uint8_t* data, std::size_t size) {
  WireReader in(data, size);
  in.skip(8 + 8 + 8);
  std::int32_t length = 0;
  in.read(length);
  in.skip(static_cast<std::size_t>(length));
  in.read(length);
  in.skip(static_cast<std::size_t>(length));
  std::int8_t state = 0;
  std::int32_t stream_width = 0, stream_height = 0, width = 0, height = 0, scale = 0;
  in.read(state);
  in.read(stream_width);
  in.read(stream_height);
  in.read(width);
  in.read(height);
  in.read(scale);
  if (state != occmap::camera_frame_t::STATE_STARTING &&
      state != occmap::camera_frame_t::STATE_STREAMING &&
      state != occmap::camera_frame_t::STATE_DOWN) {
    return "state is none of camera_frame_t's (0 starting, 1 streaming, 2 down)";
  }
  if (stream_width < 1 || stream_height < 1) return "the stream's size is not positive";
  if (scale < 1) return "scale is below 1";
  if (width != previewSide(stream_width, scale) || height != previewSide(stream_height, scale)) {
    return "width or height is not the stream's at the scale (ceil(stream / scale))";
  }
  std::int32_t jpeg_size = 0;
  in.read(jpeg_size);
  if (jpeg_size < 2 || data[in.position()] != 0xFF || data[in.position() + 1] != 0xD8) {
    return "the jpeg does not begin as a JPEG (FF D8)";
  }
  in.skip(static_cast<std::size_t>(jpeg_size));
  std::int32_t changed_size = 0;
  in.read(changed_size);
  const std::size_t pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (static_cast<std::size_t>(changed_size) != packedBytes(pixels)) {
    return "changed_size is not ceil(width * height / 8)";
  }
  in.skip(static_cast<std::size_t>(changed_size));
  std::int32_t map_width = 0, map_height = 0, coverage_size = 0;
  in.read(map_width);
  in.read(map_height);
  in.read(coverage_size);
  if (map_width < 1 || map_height < 1) return "the map's size is not positive";
  if (map_width > kMaxPreviewMapSide || map_height > kMaxPreviewMapSide) {
    return "the map is larger than 8192 cells a side";
  }
  if (coverage_size < 1) return "the coverage is empty (it is a zstd frame)";
  return "";
}

// The request's camera, pointing into `data`, or nothing (lcmtypes/camera_preview_request_t.lcm).
std::optional<std::string_view> requestedCamera(const std::uint8_t* data, std::size_t size) {
  if (data == nullptr) return std::nullopt;
  WireReader in(data, size);
  std::int64_t fingerprint = 0;
  std::int64_t utime = 0;
  if (!in.read(fingerprint) || fingerprint != occmap::camera_preview_request_t::getHash()) {
    return std::nullopt;
  }
  const char* camera = nullptr;
  std::size_t length = 0;
  if (!in.read(utime) || !in.readString(camera, length) || in.remaining() != 0) {
    return std::nullopt;
  }
  return std::string_view(camera, length);
}

}  // namespace

std::string cameraPreviewRequestChannel(const std::string& status_channel) {
  return status_channel + "_PREVIEW_REQUEST";
}

std::string cameraPreviewChannel(const std::string& status_channel) {
  return status_channel + "_PREVIEW";
}

int previewScale(int stream_width) {
  return std::max(1, (stream_width + kMaxPreviewWidth - 1) / kMaxPreviewWidth);
}

int previewSide(int stream_side, int scale) {
  return static_cast<int>((static_cast<std::int64_t>(stream_side) + scale - 1) / scale);
}

void packBits(std::span<const std::uint8_t> values, std::span<std::uint8_t> packed) {
  const std::size_t bytes = packedBytes(values.size());
  if (packed.size() < bytes) throw std::invalid_argument("packBits: too few bytes for the bits");
  std::fill_n(packed.begin(), bytes, std::uint8_t{0});
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (values[i] != 0) packed[i / 8] |= static_cast<std::uint8_t>(0x80u >> (i % 8));
  }
}

std::vector<std::uint8_t> unpackBits(std::span<const std::uint8_t> packed, std::size_t count) {
  if (packed.size() < packedBytes(count)) return {};
  std::vector<std::uint8_t> values(count);
  for (std::size_t i = 0; i < count; ++i) values[i] = (packed[i / 8] >> (7 - i % 8)) & 1u;
  return values;
}

std::vector<std::uint8_t> compressCoverage(std::span<const std::uint8_t> packed) {
  std::vector<std::uint8_t> out(ZSTD_compressBound(packed.size()));
  // ZSTD_compress writes the content size into the frame's header: the client checks it.
  const std::size_t size =
      ZSTD_compress(out.data(), out.size(), packed.data(), packed.size(), kCoverageZstdLevel);
  if (ZSTD_isError(size)) {
    throw std::runtime_error(std::string("coverage: zstd: ") + ZSTD_getErrorName(size));
  }
  out.resize(size);
  return out;
}

std::vector<std::uint8_t> encodeCameraPreviewRequest(std::int64_t utime,
                                                     const std::string& camera) {
  occmap::camera_preview_request_t request{};
  request.utime = utime;
  request.camera = camera;
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(request.getEncodedSize()));
  request.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

std::optional<std::string_view> decodeCameraPreviewRequest(const std::uint8_t* data,
                                                           std::size_t size) {
  // Walked here, not decoded by LCM's decoder: that would copy the name into a std::string.
  return requestedCamera(data, size);
}

std::size_t encodeCameraPreview(const occmap::camera_preview_t& preview,
                                std::vector<std::uint8_t>& out) {
  const int size = preview.getEncodedSize();
  out.resize(static_cast<std::size_t>(size));
  if (preview.encode(out.data(), 0, size) != size) {
    throw std::runtime_error("camera_preview_t: LCM's encoder did not fill the message");
  }
  return out.size();
}

std::optional<occmap::camera_preview_t> decodeCameraPreview(const std::uint8_t* data,
                                                            std::size_t size, std::string* error) {
  return decodeWalked<occmap::camera_preview_t>(data, size, error, previewLayoutError,
                                                previewFiguresError);
}

std::vector<std::uint8_t> previewChangedPixels(const occmap::camera_preview_t& preview) {
  return unpackBits(preview.changed, static_cast<std::size_t>(preview.width) *
                                         static_cast<std::size_t>(preview.height));
}

std::optional<std::vector<std::uint8_t>> previewCoverage(const occmap::camera_preview_t& preview,
                                                         std::string* error) {
  auto refuse = [error](std::string why) -> std::optional<std::vector<std::uint8_t>> {
    if (error != nullptr) *error = std::move(why);
    return std::nullopt;
  };
  if (preview.map_width < 1 || preview.map_height < 1 || preview.map_width > kMaxPreviewMapSide ||
      preview.map_height > kMaxPreviewMapSide) {
    return refuse("the map's size is not 1 to 8192 cells a side");
  }
  const std::size_t cells =
      static_cast<std::size_t>(preview.map_width) * static_cast<std::size_t>(preview.map_height);
  const std::size_t bytes = packedBytes(cells);
  const std::uint8_t* frame = preview.coverage.data();
  const std::size_t compressed = preview.coverage.size();
  std::string why = zstdFrameProblem(frame, compressed, bytes, "the size of the map's bits");
  if (!why.empty()) return refuse("the coverage: " + why);
  try {
    std::vector<std::uint8_t> packed(bytes);
    why = decompressZstdFrame(nullptr, frame, compressed, packed.data(), bytes);
    if (!why.empty()) return refuse("the coverage: " + why);
    return unpackBits(packed, cells);
  } catch (const std::bad_alloc&) {
    return refuse("out of memory while unpacking the coverage");
  }
}

}  // namespace occmap
