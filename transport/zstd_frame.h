#pragma once
// One zstd frame from the network, decompressed only when it is exactly what its message says:
// for map_frame_t's and map_tile_t's cells and camera_preview_t's coverage bits alike. And the
// encoders' side: zstd's compression in a workspace of its own that never allocates.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

struct ZSTD_CCtx_s;
struct ZSTD_DCtx_s;

namespace occmap {

// Why `frame` (`size` bytes) is not one zstd frame that declares exactly `expected` bytes of
// content with nothing after it ("the zstd frame says it holds N bytes, but <expected_is> = M",
// "1 bytes after its zstd frame", ...), or "": checked before the caller allocates anything for the
// content, so that a lying frame costs no memory.
std::string zstdFrameProblem(const std::uint8_t* frame, std::size_t size, std::size_t expected,
                             std::string_view expected_is);
// A frame zstdFrameProblem() passed, decompressed into `out` (`expected` bytes): "" when it held
// exactly what it declared, else why not. `context` may be null (zstd's own).
std::string decompressZstdFrame(ZSTD_DCtx_s* context, const std::uint8_t* frame, std::size_t size,
                                std::uint8_t* out, std::size_t expected);

// zstd's compression at one level in a fixed workspace: a context there never allocates (a
// workspace too small would make compression fail, not grow), sized for any source size, and
// warmed up on `warm_up_bytes` of unseen cells so that any lazy set-up happens in the
// constructor, not on a map's path. MapEncoder's and MapTileEncoder's. Throws std::runtime_error
// ("<owner>: ...") when zstd cannot be set up.
class ZstdCompressor {
 public:
  ZstdCompressor(int level, std::size_t warm_up_bytes, const char* owner);

  // `in` compressed into `out` as one frame that declares its content size: its size, or 0 when
  // it does not fit in `capacity` or zstd fails (then `error` says why, a static text).
  std::size_t compress(std::uint8_t* out, std::size_t capacity, const std::uint8_t* in,
                       std::size_t size, const char** error = nullptr);

 private:
  int level_;
  std::unique_ptr<std::uint64_t[]> workspace_;  // 8-byte aligned, as zstd requires
  ZSTD_CCtx_s* context_ = nullptr;              // lives inside workspace_: nothing else to free
};

}  // namespace occmap
