#pragma once
// One zstd frame from the network, decompressed only when it is exactly what its message says:
// for map_frame_t's and map_tile_t's cells and camera_preview_t's coverage bits alike.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

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

}  // namespace occmap
