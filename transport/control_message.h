#pragma once
// Control requests and replies (docs/control.md): control_request_t, which changes what occmapd is
// doing (a camera's threshold, its background), and control_reply_t, the daemon's answer. LCM has
// no authentication, so each carries an HMAC-SHA256 (libsodium) under a key shared by the daemon
// and its operators: the mac of a message is the HMAC of every byte of its encoding before the
// mac field, which is the message's last 32 bytes (the 8-byte fingerprint included, so a reply can
// never pass for a request). As with the status messages (status_message.h), a message from the
// network is walked field by field and every length checked against the bytes received before
// anything trusts it. No exception leaves these functions.

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <occmap/control_reply_t.hpp>
#include <occmap/control_request_t.hpp>

#include "base/control_key.h"

namespace occmap {

// Where requests go and replies come from: the status channel's name + "_CONTROL" and
// + "_CONTROL_REPLY" (OCCMAP_STATUS_CONTROL, OCCMAP_STATUS_CONTROL_REPLY by default).
std::string controlRequestChannel(const std::string& status_channel);
std::string controlReplyChannel(const std::string& status_channel);
// Where occmapd publishes control_status_t, with each status_t: the status channel's name +
// "_CONTROL_STATUS" (OCCMAP_STATUS_CONTROL_STATUS by default).
std::string controlStatusChannel(const std::string& status_channel);

// 64 random bits, for control_request_t.nonce and request_id.
std::int64_t randomControlNonce();

inline constexpr std::size_t kControlMacBytes = 32;
// No valid request comes near this (strings are bounded below); anything longer is refused
// before it is walked.
inline constexpr std::size_t kMaxControlRequestBytes = 512;
inline constexpr std::size_t kMaxControlCommandLength = 32;
inline constexpr std::size_t kMaxControlCameraLength = 64;  // camera names (config.h)

// The commands, as control_request_t.command spells them.
inline constexpr std::string_view kSetThreshold = "set_threshold";
inline constexpr std::string_view kRecaptureBackground = "recapture_background";

// A request's fields as read; the texts point into the received bytes (valid while they are).
struct ControlRequestFields {
  std::int64_t request_id = 0;
  std::int64_t utime = 0;
  std::int64_t nonce = 0;
  std::string_view command;
  std::string_view camera;
  std::int32_t value = 0;
};

// The fields of a control_request_t, or nothing when the bytes are not exactly one (another
// fingerprint, truncated, trailing bytes, oversized, a text longer than allowed or holding a NUL);
// then `why`, if given, says which. Checks the layout only, not the mac. Allocates nothing:
// occmapd's LCM thread calls it for every message on the control channel.
std::optional<ControlRequestFields> parseControlRequest(const std::uint8_t* data, std::size_t size,
                                                        const char** why = nullptr);

// Whether the message's last 32 bytes are the HMAC-SHA256 under `key` of the bytes before them,
// compared in constant time. False for a message shorter than the mac. Allocates nothing.
bool controlMacMatches(const ControlKey& key, const std::uint8_t* data, std::size_t size);

// Writes the mac of message[0, size - 32) into its last 32 bytes.
void signControlMessage(const ControlKey& key, std::span<std::uint8_t> message);

// A request encoded and signed, as `occmap control` sends it (its mac field is ignored).
std::vector<std::uint8_t> encodeControlRequest(const ControlKey& key,
                                               const occmap::control_request_t& request);

// A reply encoded and signed into `buffer`, which is reused: once it has grown to the size of the
// longest reply, this allocates nothing (occmapd's LCM thread).
void encodeControlReply(const ControlKey& key, const occmap::control_reply_t& reply,
                        std::vector<std::uint8_t>& buffer);

// A control_reply_t that is exactly one message and carries the right mac, or nothing (`why`
// says why): what `occmap control` believes.
std::optional<occmap::control_reply_t> decodeControlReply(const ControlKey& key,
                                                          const std::uint8_t* data,
                                                          std::size_t size,
                                                          std::string* why = nullptr);

}  // namespace occmap
