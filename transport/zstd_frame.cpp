#include "transport/zstd_frame.h"

#define ZSTD_STATIC_LINKING_ONLY  // ZSTD_initStaticCCtx: a compression context that cannot allocate
#include <stdexcept>
#include <vector>

#include <zstd.h>

#include "core/map_geometry.h"

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

ZstdCompressor::ZstdCompressor(int level, std::size_t warm_up_bytes, const char* owner)
    : level_(level) {
  const std::size_t bytes = ZSTD_estimateCCtxSize(level);
  workspace_ = std::make_unique<std::uint64_t[]>((bytes + 7) / 8);
  context_ = ZSTD_initStaticCCtx(workspace_.get(), (bytes + 7) / 8 * 8);
  if (context_ == nullptr) {
    throw std::runtime_error(std::string(owner) + ": cannot set up zstd's context");
  }
  // Unseen cells, as a map before any camera has said anything.
  const std::vector<std::uint8_t> unseen(warm_up_bytes,
                                         static_cast<std::uint8_t>(CellState::kUnseen));
  std::vector<std::uint8_t> out(ZSTD_compressBound(warm_up_bytes));
  const char* error = "";
  if (warm_up_bytes > 0 &&
      compress(out.data(), out.size(), unseen.data(), unseen.size(), &error) == 0) {
    throw std::runtime_error(std::string(owner) + ": zstd: " + error);
  }
}

std::size_t ZstdCompressor::compress(std::uint8_t* out, std::size_t capacity,
                                     const std::uint8_t* in, std::size_t size, const char** error) {
  const std::size_t written = ZSTD_compressCCtx(context_, out, capacity, in, size, level_);
  if (ZSTD_isError(written)) {
    if (error != nullptr) *error = ZSTD_getErrorName(written);
    return 0;
  }
  return written;
}

}  // namespace occmap
