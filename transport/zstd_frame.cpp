#include "transport/zstd_frame.h"

#include <zstd.h>

namespace occmap {

std::string zstdFrameProblem(const std::uint8_t* frame, std::size_t size, std::size_t expected,
                             std::string_view expected_is) {
  const unsigned long long content = ZSTD_getFrameContentSize(frame, size);
  if (content == ZSTD_CONTENTSIZE_ERROR) return "the data is not a zstd frame";
  if (content == ZSTD_CONTENTSIZE_UNKNOWN)
    return "the zstd frame does not declare its content size";
  if (content != expected) {
    return "the zstd frame says it holds " + std::to_string(content) + " bytes, but " +
           std::string(expected_is) + " = " + std::to_string(expected);
  }
  const std::size_t frame_size = ZSTD_findFrameCompressedSize(frame, size);
  if (ZSTD_isError(frame_size)) {
    return std::string("corrupt zstd frame: ") + ZSTD_getErrorName(frame_size);
  }
  if (frame_size != size) {
    return "the data holds " + std::to_string(size - frame_size) + " bytes after its zstd frame";
  }
  return "";
}

std::string decompressZstdFrame(ZSTD_DCtx_s* context, const std::uint8_t* frame, std::size_t size,
                                std::uint8_t* out, std::size_t expected) {
  const std::size_t size_out = context != nullptr
                                   ? ZSTD_decompressDCtx(context, out, expected, frame, size)
                                   : ZSTD_decompress(out, expected, frame, size);
  if (ZSTD_isError(size_out)) {
    return std::string("corrupt zstd frame: ") + ZSTD_getErrorName(size_out);
  }
  if (size_out != expected) {
    return "the zstd frame decompressed to " + std::to_string(size_out) + " bytes, not " +
           std::to_string(expected);
  }
  return "";
}

}  // namespace occmap
