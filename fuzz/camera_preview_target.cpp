// camera_preview: a camera_preview_t as the live view (`occmap web`, web/bus_feed.cpp) reads it
// from the preview channel (transport/camera_preview_message.h): decodeCameraPreview, then the map
// cells the camera decides, unpacked from their zstd frame (previewCoverage; a preview whose
// coverage is refused is refused), and its changed pixels (previewChangedPixels). Anyone on the
// network segment can publish on the channel. Accepted: decoded and its coverage unpacked.
//
// Checked on what is accepted: the figures agree as the header says (state, the preview's size at
// its scale, ceil(width * height / 8) changed bytes, a map of 1..8192 cells a side, a JPEG's first
// bytes); encoded again by occmapd's own encoder, the same bytes; width * height changed values
// and map_width * map_height coverage values, each 0 or 1 and the message's bits. The coverage's
// zstd frame is read apart with zstd's one-shot functions: it is accepted exactly when it is one
// frame that declares ceil(map cells / 8) bytes and holds them. What the three allocate (counted in
// the fuzz build, fuzz/heap_use.h) is within the sizes the message declares: the message's own
// bytes, width * height, and the map's bits packed and unpacked plus zstd's fixed context.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <occmap/camera_frame_t.hpp>
#include <occmap/camera_preview_t.hpp>
#include <zstd.h>

#include "fuzz/fuzz_target.h"
#include "fuzz/heap_use.h"
#include "transport/camera_preview_message.h"

namespace occmap::fuzz {
namespace {

// What zstd's one-shot decompression allocates whatever the frame (its context, about 160 KB in
// zstd 1.5; the output is the caller's), with room to spare; and room for a refusal's text.
constexpr std::size_t kZstdContextBytes = std::size_t{1} << 20;
constexpr std::size_t kErrorTextBytes = 1024;

// `values` (0 or 1 each) are the first values.size() bits of `packed`, most significant first
// (the padding bits of the last byte are not looked at: the decoders do not either).
bool areTheBits(const std::vector<std::uint8_t>& values, const std::uint8_t* packed,
                std::size_t packed_size) {
  if (packed_size < packedBytes(values.size())) return false;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (values[i] != ((packed[i / 8] >> (7 - i % 8)) & 1u)) return false;
  }
  return true;
}

bool zeroOrOne(const std::vector<std::uint8_t>& values) {
  return std::all_of(values.begin(), values.end(), [](std::uint8_t v) { return v <= 1; });
}

// The coverage read apart: whether its bytes are one zstd frame declaring `bytes` bytes and holding
// exactly them, which are then in `packed`. Only a frame that declares `bytes` is decompressed, so
// that this allocates no more than the client may.
bool readCoverageApart(const std::vector<std::uint8_t>& coverage, std::size_t bytes,
                       std::vector<std::uint8_t>& packed) {
  const unsigned long long declared = ZSTD_getFrameContentSize(coverage.data(), coverage.size());
  if (declared == ZSTD_CONTENTSIZE_ERROR || declared == ZSTD_CONTENTSIZE_UNKNOWN ||
      declared != bytes) {
    return false;
  }
  const std::size_t frame = ZSTD_findFrameCompressedSize(coverage.data(), coverage.size());
  if (ZSTD_isError(frame) || frame != coverage.size()) return false;
  packed.assign(bytes + 1, 0);  // a byte more than declared: a frame that holds more shows it
  const std::size_t out =
      ZSTD_decompress(packed.data(), packed.size(), coverage.data(), coverage.size());
  return !ZSTD_isError(out) && out == bytes;
}

}  // namespace

bool fuzzCameraPreview(Input input) {
  std::string error;
  std::optional<occmap::camera_preview_t> decoded;
  {
    const HeapUse heap;
    decoded = decodeCameraPreview(input.data(), input.size(), &error);
    require(!heap.counted() || heap.bytes() <= input.size() + kErrorTextBytes,
            "decodeCameraPreview allocates no more than the message's own bytes");
  }
  if (!decoded) {
    require(!error.empty(), "a refused preview says why");
    return false;  // counted as undecodable
  }
  const occmap::camera_preview_t& preview = *decoded;

  // The figures, as the header promises them of an accepted preview.
  require(preview.state == occmap::camera_frame_t::STATE_STARTING ||
              preview.state == occmap::camera_frame_t::STATE_STREAMING ||
              preview.state == occmap::camera_frame_t::STATE_DOWN,
          "an accepted preview's state is one of camera_frame_t's");
  require(preview.stream_width >= 1 && preview.stream_height >= 1 && preview.scale >= 1,
          "an accepted preview has a stream of positive size and a scale >= 1");
  require(preview.width == previewSide(preview.stream_width, preview.scale) &&
              preview.height == previewSide(preview.stream_height, preview.scale) &&
              preview.width >= 1 && preview.height >= 1,
          "an accepted preview is the stream's size at its scale, ceil(stream / scale)");
  require(preview.jpeg_size >= 2 &&
              preview.jpeg.size() == static_cast<std::size_t>(preview.jpeg_size) &&
              preview.jpeg[0] == 0xFF && preview.jpeg[1] == 0xD8,
          "an accepted preview's jpeg is jpeg_size bytes beginning as a JPEG (FF D8)");
  const std::size_t pixels =
      static_cast<std::size_t>(preview.width) * static_cast<std::size_t>(preview.height);
  require(preview.changed.size() == static_cast<std::size_t>(preview.changed_size) &&
              preview.changed.size() == packedBytes(pixels),
          "an accepted preview has ceil(width * height / 8) changed bytes");
  require(preview.map_width >= 1 && preview.map_height >= 1 &&
              preview.map_width <= kMaxPreviewMapSide && preview.map_height <= kMaxPreviewMapSide,
          "an accepted preview's map is 1..8192 cells a side");
  require(preview.coverage_size >= 1 &&
              preview.coverage.size() == static_cast<std::size_t>(preview.coverage_size),
          "an accepted preview has coverage_size bytes of coverage, at least one");
  require(preview.hostname.find('\0') == std::string::npos &&
              preview.camera.find('\0') == std::string::npos,
          "an accepted preview's texts hold no NUL");

  // Accepted means exactly one camera_preview_t: encoded again by occmapd's encoder, the same
  // bytes.
  std::vector<std::uint8_t> again;
  require(encodeCameraPreview(preview, again) == input.size() &&
              std::equal(again.begin(), again.end(), input.begin(), input.end()),
          "an accepted preview encodes back to the bytes received");

  // The changed pixels: width * height values, 0 or 1, the message's bits.
  std::vector<std::uint8_t> changed;
  {
    const HeapUse heap;
    changed = previewChangedPixels(preview);
    require(!heap.counted() || heap.bytes() <= pixels,
            "previewChangedPixels allocates no more than width * height bytes");
  }
  require(changed.size() == pixels, "an accepted preview has width * height changed pixels");
  require(zeroOrOne(changed), "the changed pixels are 0 or 1");
  require(areTheBits(changed, preview.changed.data(), preview.changed.size()),
          "the changed pixels are the message's bits, most significant first");

  // The coverage: map_width * map_height values when its frame declares and holds the map's bits.
  const std::size_t cells =
      static_cast<std::size_t>(preview.map_width) * static_cast<std::size_t>(preview.map_height);
  const std::size_t bytes = packedBytes(cells);
  std::string coverage_error;
  std::optional<std::vector<std::uint8_t>> coverage;
  {
    const HeapUse heap;
    coverage = previewCoverage(preview, &coverage_error);
    require(!heap.counted() || heap.bytes() <= bytes + cells + kZstdContextBytes + kErrorTextBytes,
            "previewCoverage allocates no more than the map's bits, packed and unpacked, and "
            "zstd's context, whatever size the frame declares");
  }
  std::vector<std::uint8_t> packed;
  const bool sound = readCoverageApart(preview.coverage, bytes, packed);
  if (!coverage) {
    require(!coverage_error.empty(), "a refused coverage says why");
    require(!sound,
            "a coverage that is one zstd frame declaring and holding the map's bits is not "
            "refused");
    return false;  // occmap web refuses the preview (web/bus_feed.cpp)
  }
  require(sound,
          "an accepted coverage is one zstd frame that declares ceil(map_width * map_height / 8) "
          "bytes and holds exactly them");
  require(coverage->size() == cells, "an accepted coverage has map_width * map_height values");
  require(zeroOrOne(*coverage), "the coverage's values are 0 or 1");
  require(areTheBits(*coverage, packed.data(), bytes),
          "the coverage's values are the bits of its zstd frame, most significant first");
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzCameraPreview)
