#pragma once
// The V4L2 test shim's contract with the tests: the environment variables that shape the device
// it serves, and the picture it draws, so that a test can check every pixel it receives.
//
// LD_PRELOAD=liboccmap_v4l2_shim.so and set OCCMAP_V4L2_SHIM_DEVICE=/dev/video42: opening that path
// opens a camera made of memory (a memfd) that answers the ioctls a capture driver answers. The
// device reads the other variables when it is first opened (and after each unplug), so a test can
// change them between devices.

#include <cstdint>

namespace occmap::v4l2_shim {

// The path served, e.g. /dev/video42. Unset: the shim passes everything through.
inline constexpr const char* kDeviceVariable = "OCCMAP_V4L2_SHIM_DEVICE";
// Pixel formats offered, in VIDIOC_ENUM_FMT's order (default "GREY,YUYV").
inline constexpr const char* kFormatsVariable = "OCCMAP_V4L2_SHIM_FORMATS";
// Frame sizes the sensor can do; the first is the default (default "640x480,320x240").
inline constexpr const char* kSizesVariable = "OCCMAP_V4L2_SHIM_SIZES";
// Bytes of padding the driver puts after every row (bytesperline = row + padding; default 0).
inline constexpr const char* kPaddingVariable = "OCCMAP_V4L2_SHIM_PADDING";
// Frame rates it can do, whole frames per second; the first is the default (default "30,60").
inline constexpr const char* kRatesVariable = "OCCMAP_V4L2_SHIM_RATES";
// Every Nth frame (frame numbers N-1, 2N-1, ...) comes with V4L2_BUF_FLAG_ERROR (default 0: none).
inline constexpr const char* kErrorEveryVariable = "OCCMAP_V4L2_SHIM_ERROR_EVERY";
// While this file exists the device is unplugged: open() says ENOENT, every open descriptor of it
// is dead for good (ioctls ENODEV, poll POLLERR|POLLHUP). Once it is removed, open() works again
// on a freshly plugged device (default format, controls at their defaults).
inline constexpr const char* kUnplugFileVariable = "OCCMAP_V4L2_SHIM_UNPLUG_FILE";
// While this file exists the driver stalls: it streams but finishes no frame. A stream that stalled
// stays stalled, even once the file is gone, until it is stopped and started again (STREAMOFF,
// STREAMON): as with drivers that get stuck, a reopen is what brings it back.
inline constexpr const char* kStallFileVariable = "OCCMAP_V4L2_SHIM_STALL_FILE";
// Set (to anything): the device cannot stream (no V4L2_CAP_STREAMING), like a read()-only driver.
inline constexpr const char* kNoStreamingVariable = "OCCMAP_V4L2_SHIM_NO_STREAMING";

// The shim exports this C symbol: a test looks it up to know the shim is loaded.
inline constexpr const char* kLoadedSymbol = "occmap_v4l2_shim_loaded";

// Pixels are never 255 nor below 16, so that padding (kPaddingByte) and chroma (kChromaU,
// kChromaV) taken for a pixel are always caught.
inline constexpr std::uint8_t kPaddingByte = 255;
inline constexpr std::uint8_t kChromaU = 250;
inline constexpr std::uint8_t kChromaV = 5;

// The luminance of pixel (u, v) in frame `frame` (the driver's sequence number, from 0 at
// STREAMON), with the Gain control at `gain`: a ramp that moves 7 levels a frame.
inline std::uint8_t patternLuminance(std::uint64_t frame, int u, int v, int gain) {
  const std::uint64_t ramp = static_cast<std::uint64_t>(u) + 3 * static_cast<std::uint64_t>(v) +
                             7 * frame + static_cast<std::uint64_t>(gain);
  return static_cast<std::uint8_t>(16 + ramp % 200);
}

// The shim's controls (QUERYCTRL names and ranges), besides the two control classes.
inline constexpr int kGainDefault = 0;
inline constexpr int kGainMaximum = 100;
// Exposure runs 1, 11, 21, ... 9991: the driver rounds a value onto that step.
inline constexpr int kExposureDefault = 101;
inline constexpr int kExposureMaximum = 9991;
inline constexpr int kExposureStep = 10;

}  // namespace occmap::v4l2_shim
