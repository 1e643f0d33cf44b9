#pragma once
// A camera's background image (the empty scene) as the per-pixel median of frames of it: the
// median keeps what stays and drops what passes by, so people may walk through while the frames
// are taken, as long as no pixel is covered in half of them or more. Used by `occmap background`
// and by occmapd's recapture_background request (docs/control.md).

#include <cstddef>
#include <cstdint>
#include <span>

#include "core/image.h"

namespace occmap {

// `frames` holds `count` images of width x height pixels one after the other, rows packed. The
// median of an even count is the upper of the two middle values.
Image backgroundMedian(std::span<const std::uint8_t> frames, int count, int width, int height);

}  // namespace occmap
