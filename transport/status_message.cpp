#include "transport/status_message.h"

#include <climits>
#include <exception>

#include <occmap/status_request_t.hpp>

#include "transport/wire_reader.h"

namespace occmap {
namespace {

template <typename T>
bool skipField(WireReader& in) {
  T ignored{};
  return in.read(ignored);
}

// Reads fields of the given types, in order; false as soon as one does not fit.
template <typename... T>
bool readAll(WireReader& in) {
  return (skipField<T>(in) && ...);
}

bool readStrings(WireReader& in, int count) {
  for (int k = 0; k < count; ++k) {
    const char* text = nullptr;
    std::size_t length = 0;
    if (!in.readString(text, length)) return false;
  }
  return true;
}

// Why the bytes are not one status_t, or "" when every count agrees with the size (in the order of
// lcmtypes/status_t.lcm and camera_status_t.lcm).
const char* statusLayoutError(const std::uint8_t* data, std::size_t size) {
  WireReader in(data, size);
  std::int64_t fingerprint = 0;
  if (!in.read(fingerprint)) return "too short for an LCM message";
  if (fingerprint != occmap::status_t::getHash()) return "not an occmap.status_t (fingerprint)";
  if (!readAll<std::int64_t, std::int64_t>(in)) return "truncated in utime or request_id";
  if (!readStrings(in, 2)) return "hostname or config_file is not a string that fits";
  if (!readAll<std::int8_t, double, std::int64_t, std::int64_t, double, double, double>(in)) {
    return "truncated in the daemon's figures";
  }
  std::int16_t cameras = 0;
  if (!in.read(cameras)) return "truncated before num_cameras";
  if (cameras < 0) return "num_cameras is negative";
  for (int k = 0; k < cameras; ++k) {
    if (!readStrings(in, 2)) return "a camera's name or source is not a string that fits";
    if (!readAll<std::int8_t, std::int64_t, std::int64_t, double, std::int64_t, std::int64_t,
                 std::int64_t, std::int64_t, std::int64_t, std::int32_t>(in)) {
      return "truncated in a camera's figures";
    }
    if (!readStrings(in, 1)) return "a camera's last_error is not a string that fits";
  }
  if (in.remaining() != 0) return "bytes left over: the counts do not add up to the size";
  return "";
}

// The same for control_status_t (lcmtypes/control_status_t.lcm).
const char* controlStatusLayoutError(const std::uint8_t* data, std::size_t size) {
  WireReader in(data, size);
  std::int64_t fingerprint = 0;
  if (!in.read(fingerprint)) return "too short for an LCM message";
  if (fingerprint != occmap::control_status_t::getHash()) {
    return "not an occmap.control_status_t (fingerprint)";
  }
  if (!readAll<std::int64_t, std::int64_t>(in)) return "truncated in utime or request_id";
  if (!readStrings(in, 1)) return "hostname is not a string that fits";
  if (!readAll<std::int8_t, std::int64_t, std::int64_t, std::int64_t, std::int64_t, std::int64_t,
               std::int64_t>(in)) {
    return "truncated in the control counts";
  }
  std::int16_t cameras = 0;
  if (!in.read(cameras)) return "truncated before num_cameras";
  if (cameras < 0) return "num_cameras is negative";
  if (!readStrings(in, cameras)) return "a camera's name is not a string that fits";
  // camera_threshold[num_cameras] (int32), then camera_background_utime[num_cameras] (int64): at
  // most 32767 * 12 bytes, no overflow.
  if (!in.skip(static_cast<std::size_t>(cameras) * (4 + 8))) {
    return "truncated in the cameras' thresholds or background times";
  }
  if (in.remaining() != 0) return "bytes left over: the counts do not add up to the size";
  return "";
}

// The companions of status_t that are fixed-size fields per camera after a common head
// (lighting_status_t, view_status_t): the head is fingerprint, utime, request_id, hostname,
// num_cameras and the camera names; then `bytes_per_camera` for each camera, at most 32767 of them
// (no overflow). "" when every count agrees with the size.
const char* perCameraLayoutError(const std::uint8_t* data, std::size_t size, std::int64_t hash,
                                 const char* other_fingerprint, std::size_t bytes_per_camera) {
  WireReader in(data, size);
  std::int64_t fingerprint = 0;
  if (!in.read(fingerprint)) return "too short for an LCM message";
  if (fingerprint != hash) return other_fingerprint;
  if (!readAll<std::int64_t, std::int64_t>(in)) return "truncated in utime or request_id";
  if (!readStrings(in, 1)) return "hostname is not a string that fits";
  std::int16_t cameras = 0;
  if (!in.read(cameras)) return "truncated before num_cameras";
  if (cameras < 0) return "num_cameras is negative";
  if (!readStrings(in, cameras)) return "a camera's name is not a string that fits";
  if (!in.skip(static_cast<std::size_t>(cameras) * bytes_per_camera)) {
    return "truncated in the cameras' figures";
  }
  if (in.remaining() != 0) return "bytes left over: the counts do not add up to the size";
  return "";
}

// lighting_status_t (lcmtypes/lighting_status_t.lcm): adapt (int8), gain, agreement (double),
// explained (int8), unexplained_frames (int64) per camera.
const char* lightingStatusLayoutError(const std::uint8_t* data, std::size_t size) {
  return perCameraLayoutError(data, size, occmap::lighting_status_t::getHash(),
                              "not an occmap.lighting_status_t (fingerprint)", 1 + 8 + 8 + 1 + 8);
}

// view_status_t (lcmtypes/view_status_t.lcm): view (int8), shift_x_px, shift_y_px, turn_deg,
// residual_px (double), checked_utime (int64), reposes (int32), reposed_turn_deg (double),
// reposed_utime (int64) per camera.
const char* viewStatusLayoutError(const std::uint8_t* data, std::size_t size) {
  return perCameraLayoutError(data, size, occmap::view_status_t::getHash(),
                              "not an occmap.view_status_t (fingerprint)",
                              1 + 4 * 8 + 8 + 4 + 8 + 8);
}

}  // namespace

std::optional<occmap::view_status_t> decodeViewStatus(const std::uint8_t* data, std::size_t size,
                                                      std::string* error) {
  return decodeWalked<occmap::view_status_t>(data, size, error, viewStatusLayoutError);
}

std::optional<occmap::lighting_status_t> decodeLightingStatus(const std::uint8_t* data,
                                                              std::size_t size,
                                                              std::string* error) {
  return decodeWalked<occmap::lighting_status_t>(data, size, error, lightingStatusLayoutError);
}

std::optional<std::int64_t> decodeStatusRequest(const std::uint8_t* data, std::size_t size) {
  // Fixed-size fields only: LCM's decoder checks each against the length, so it is safe as it is.
  if (data == nullptr || size > static_cast<std::size_t>(INT_MAX)) return std::nullopt;
  occmap::status_request_t request{};
  if (request.decode(data, 0, static_cast<int>(size)) != static_cast<int>(size)) {
    return std::nullopt;
  }
  return request.request_id;
}

std::optional<occmap::status_t> decodeStatus(const std::uint8_t* data, std::size_t size,
                                             std::string* error) {
  return decodeWalked<occmap::status_t>(data, size, error, statusLayoutError);
}

std::optional<occmap::control_status_t> decodeControlStatus(const std::uint8_t* data,
                                                            std::size_t size, std::string* error) {
  return decodeWalked<occmap::control_status_t>(data, size, error, controlStatusLayoutError);
}

}  // namespace occmap
