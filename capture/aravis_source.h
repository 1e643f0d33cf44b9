#pragma once
// The Aravis backend's pixel formats: which GenICam formats occmap takes and how each becomes the
// 8-bit image fusion compares. (The source itself: openAravisSource in capture/live_source.h.)

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>

#include "core/image.h"

namespace occmap {

// The GenICam pixel formats occmap takes (PFNC codes, as Aravis names them).
enum class CameraPixels {
  kMono8,       // used as it is
  kBayer8,      // raw Bayer (any of the four orders), compared raw against a raw Bayer background:
                // the difference needs no colour, so no demosaicing
  kRgb8,        // reduced to luminance
  kBgr8,        // reduced to luminance
  kYuv422Yuyv,  // its Y samples are the luminance
  kYuv422Uyvy,  // (GenICam's YUV422Packed) likewise
};

// Empty for a format occmap does not take.
std::optional<CameraPixels> cameraPixelsOf(std::uint32_t pixel_format);
// "Mono8, BayerRG8 (or GR, GB, BG), RGB8, BGR8, YUV422_8 (YUYV), YUV422Packed (UYVY)".
std::string_view cameraPixelsTaken();
// Whether frames of this format are the 8-bit image already (no conversion, no copy).
bool isEightBitImage(CameraPixels pixels);
// Bytes per pixel of a packed row in this format.
int bytesPerPixel(CameraPixels pixels);

// Writes the frame's 8-bit image into `out` (width x height, packed): luminance as OpenCV
// computes it for RGB/BGR (the same as files:// images get), the Y samples for YUV 4:2:2, the
// bytes themselves for Mono8 and Bayer. `stride` is the bytes from one input row to the next.
void reduceToLuminance(CameraPixels pixels, const std::uint8_t* data, int width, int height,
                       std::ptrdiff_t stride, std::uint8_t* out);

}  // namespace occmap
