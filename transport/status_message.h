#pragma once
// The status messages as they arrive from the network: status_request_t (read by occmapd) and
// status_t and control_status_t (read by `occmap status` and any client). Anyone on the network
// segment can publish them, so a message is walked field by field and every count checked against
// the bytes received before LCM's generated decoder sees it: that decoder trusts a string's length
// (0 or a negative one makes std::string::assign throw, INT32_MIN overflows a signed int) and sizes
// its vectors from a count that may be negative. No exception leaves these functions.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include <occmap/control_status_t.hpp>
#include <occmap/lighting_status_t.hpp>
#include <occmap/status_t.hpp>
#include <occmap/view_status_t.hpp>

namespace occmap {

// The request id of a status_request_t, or nothing when the bytes are not exactly one such message
// (another fingerprint, truncated, trailing bytes). Allocates nothing: occmapd's LCM thread calls
// it for every message on the request channel.
std::optional<std::int64_t> decodeStatusRequest(const std::uint8_t* data, std::size_t size);

// A status_t, or nothing when the bytes are not exactly one; then `error`, if given, says why.
std::optional<occmap::status_t> decodeStatus(const std::uint8_t* data, std::size_t size,
                                             std::string* error = nullptr);

// A control_status_t, or nothing when the bytes are not exactly one; then `error`, if given, says
// why. Checked the same way as a status_t.
std::optional<occmap::control_status_t> decodeControlStatus(const std::uint8_t* data,
                                                            std::size_t size,
                                                            std::string* error = nullptr);

// A lighting_status_t, or nothing when the bytes are not exactly one; then `error`, if given, says
// why. Checked the same way as a status_t.
std::optional<occmap::lighting_status_t> decodeLightingStatus(const std::uint8_t* data,
                                                              std::size_t size,
                                                              std::string* error = nullptr);

// A view_status_t, or nothing when the bytes are not exactly one; then `error`, if given, says
// why. Checked the same way as a status_t.
std::optional<occmap::view_status_t> decodeViewStatus(const std::uint8_t* data, std::size_t size,
                                                      std::string* error = nullptr);

}  // namespace occmap
