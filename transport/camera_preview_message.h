#pragma once
// Camera previews on the bus (issue 17, docs/daemon.md "Camera previews"): camera_preview_request_t
// (a client asks) and camera_preview_t (occmapd answers with each camera's frame, its changed
// pixels and its coverage), their channels, what the daemon encodes them with, and the decoders a
// client reads them with. Anyone on the network segment can publish on these channels, so a
// message is walked field by field and every count checked against the bytes received before LCM's
// generated decoder (which trusts them) sees it, as status_message.h does for status_t; the bits
// a client unpacks are checked again against the sizes the message declares. No exception leaves
// the decoders.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <occmap/camera_preview_t.hpp>

namespace occmap {

// Where previews are asked for: the status channel's name + "_PREVIEW_REQUEST"
// (OCCMAP_STATUS_PREVIEW_REQUEST by default).
std::string cameraPreviewRequestChannel(const std::string& status_channel);
// Where occmapd publishes them: the status channel's name + "_PREVIEW" (OCCMAP_STATUS_PREVIEW).
std::string cameraPreviewChannel(const std::string& status_channel);

// Every camera_preview_t fits one UDP datagram with LCM's header and the channel's name.
inline constexpr std::size_t kMaxPreviewMessageBytes = 61'440;
// A preview is at most this wide at its own scale (a larger scale when a message would not fit).
inline constexpr int kMaxPreviewWidth = 320;
// The largest map a preview's coverage may declare: the config's own limit (8192 cells a side),
// so that a lying message cannot make a client inflate gigabytes from a small zstd frame.
inline constexpr int kMaxPreviewMapSide = 8192;

// The smallest integer scale that makes a stream of `stream_width` pixels at most kMaxPreviewWidth
// wide (1 for a stream that is not wider).
int previewScale(int stream_width);
// A side of the preview at `scale`: ceil(stream_side / scale).
int previewSide(int stream_side, int scale);

// Bytes of `count` bits packed 8 to a byte: ceil(count / 8).
inline std::size_t packedBytes(std::size_t count) { return (count + 7) / 8; }
// `values` (non-zero: 1) as bits, most significant bit first, into `packed` (at least
// packedBytes(values.size()) bytes; the padding bits of the last byte are written 0).
void packBits(std::span<const std::uint8_t> values, std::span<std::uint8_t> packed);
// The first `count` bits of `packed` (most significant bit first) as one byte each, 0 or 1; empty
// when `packed` holds fewer than `count` bits.
std::vector<std::uint8_t> unpackBits(std::span<const std::uint8_t> packed, std::size_t count);

// A camera's coverage bits (packed, packedBytes(map cells) bytes) as the one zstd frame a preview
// carries, declaring its content size. Made once per camera when the daemon starts.
std::vector<std::uint8_t> compressCoverage(std::span<const std::uint8_t> packed);

// A request for previews of `camera` ("" for every camera), sent at `utime`.
std::vector<std::uint8_t> encodeCameraPreviewRequest(std::int64_t utime, const std::string& camera);
// The camera a request names ("" for all), pointing into `data` (valid while it is), or nothing
// when the bytes are not exactly one camera_preview_request_t. Allocates nothing: occmapd's
// publisher thread calls it for every message on the request channel.
std::optional<std::string_view> decodeCameraPreviewRequest(const std::uint8_t* data,
                                                           std::size_t size);

// `preview` encoded into `out` (resized to the message's size; a buffer that is reused and has
// room allocates nothing). Returns the size.
std::size_t encodeCameraPreview(const occmap::camera_preview_t& preview,
                                std::vector<std::uint8_t>& out);

// A camera_preview_t, or nothing when the bytes are not exactly one (another fingerprint,
// truncated, a count that does not fit, trailing bytes) or its figures disagree (the preview's size
// is not the stream's at its scale, the changed bits are not width * height, a map larger than
// kMaxPreviewMapSide, a state that is none, a JPEG that does not begin as one); then `error`, if
// given, says why. The coverage is checked when it is unpacked (previewCoverage).
std::optional<occmap::camera_preview_t> decodeCameraPreview(const std::uint8_t* data,
                                                            std::size_t size,
                                                            std::string* error = nullptr);

// A decoded preview's changed pixels, one byte per preview pixel (row-major from the top), 1 =
// changed.
std::vector<std::uint8_t> previewChangedPixels(const occmap::camera_preview_t& preview);
// A decoded preview's coverage, one byte per map cell (row-major from row 0), 1 = decided by the
// camera; nothing when the zstd frame is corrupt or does not hold exactly ceil(map_width *
// map_height / 8) bytes (it must declare that size); then `error`, if given, says why.
std::optional<std::vector<std::uint8_t>> previewCoverage(const occmap::camera_preview_t& preview,
                                                         std::string* error = nullptr);

}  // namespace occmap
