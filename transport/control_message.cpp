#include "transport/control_message.h"

#include <climits>
#include <cstring>
#include <exception>

#include <sodium.h>

#include "transport/wire_reader.h"

namespace occmap {

std::string controlRequestChannel(const std::string& status_channel) {
  return status_channel + "_CONTROL";
}

std::string controlReplyChannel(const std::string& status_channel) {
  return status_channel + "_CONTROL_REPLY";
}

std::string controlStatusChannel(const std::string& status_channel) {
  return status_channel + "_CONTROL_STATUS";
}

namespace {

// libsodium wants sodium_init() before its first use (it picks implementations, seeds its random
// source); once, at load, rather than on the LCM thread, where it would take a lock per message.
[[maybe_unused]] const int sodium_ready = sodium_init();

void macOf(const ControlKey& key, const std::uint8_t* data, std::size_t size,
           std::uint8_t (&mac)[kControlMacBytes]) {
  crypto_auth_hmacsha256_state state;
  crypto_auth_hmacsha256_init(&state, key.bytes.data(), key.size);
  crypto_auth_hmacsha256_update(&state, data, size);
  crypto_auth_hmacsha256_final(&state, mac);
  sodium_memzero(&state, sizeof state);
}

// Why the bytes are not one control_reply_t, or "" (the order of lcmtypes/control_reply_t.lcm).
const char* replyLayoutError(const std::uint8_t* data, std::size_t size) {
  WireReader in(data, size);
  std::int64_t fingerprint = 0, utime = 0, request_id = 0;
  std::int8_t outcome = 0;
  const char* text = nullptr;
  std::size_t length = 0;
  if (!in.read(fingerprint)) return "too short for an LCM message";
  if (fingerprint != occmap::control_reply_t::getHash()) {
    return "not an occmap.control_reply_t (fingerprint)";
  }
  if (!in.read(utime) || !in.read(request_id) || !in.read(outcome)) return "truncated";
  if (!in.readString(text, length)) return "message is not a string that fits";
  if (!in.skip(kControlMacBytes)) return "truncated in the mac";
  if (in.remaining() != 0) return "bytes left over";
  return "";
}

}  // namespace

std::optional<ControlRequestFields> parseControlRequest(const std::uint8_t* data, std::size_t size,
                                                        const char** why) {
  auto refuse = [why](const char* reason) -> std::optional<ControlRequestFields> {
    if (why != nullptr) *why = reason;
    return std::nullopt;
  };
  if (data == nullptr) return refuse("no data");
  if (size > kMaxControlRequestBytes) return refuse("oversized");
  WireReader in(data, size);
  std::int64_t fingerprint = 0;
  if (!in.read(fingerprint)) return refuse("too short for an LCM message");
  if (fingerprint != occmap::control_request_t::getHash()) {
    return refuse("not an occmap.control_request_t (fingerprint)");
  }
  ControlRequestFields fields;
  if (!in.read(fields.request_id) || !in.read(fields.utime) || !in.read(fields.nonce)) {
    return refuse("truncated in request_id, utime or nonce");
  }
  const char* text = nullptr;
  std::size_t length = 0;
  if (!in.readString(text, length) || length > kMaxControlCommandLength) {
    return refuse("command is not a string that fits");
  }
  fields.command = std::string_view(text, length);
  if (!in.readString(text, length) || length > kMaxControlCameraLength) {
    return refuse("camera is not a string that fits");
  }
  fields.camera = std::string_view(text, length);
  if (!in.read(fields.value)) return refuse("truncated in value");
  if (!in.skip(kControlMacBytes)) return refuse("truncated in the mac");
  if (in.remaining() != 0) return refuse("bytes left over: the lengths do not add up to the size");
  return fields;
}

bool controlMacMatches(const ControlKey& key, const std::uint8_t* data, std::size_t size) {
  if (data == nullptr || size < kControlMacBytes || key.size < ControlKey::kMinBytes) return false;
  std::uint8_t expected[kControlMacBytes];
  macOf(key, data, size - kControlMacBytes, expected);
  const bool same = crypto_verify_32(expected, data + size - kControlMacBytes) == 0;
  sodium_memzero(expected, sizeof expected);
  return same;
}

std::int64_t randomControlNonce() {
  std::int64_t nonce = 0;
  randombytes_buf(&nonce, sizeof nonce);
  return nonce;
}

void signControlMessage(const ControlKey& key, std::span<std::uint8_t> message) {
  if (message.size() < kControlMacBytes) return;
  std::uint8_t mac[kControlMacBytes];
  macOf(key, message.data(), message.size() - kControlMacBytes, mac);
  std::memcpy(message.data() + message.size() - kControlMacBytes, mac, kControlMacBytes);
}

std::vector<std::uint8_t> encodeControlRequest(const ControlKey& key,
                                               const occmap::control_request_t& request) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(request.getEncodedSize()));
  request.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  signControlMessage(key, bytes);
  return bytes;
}

void encodeControlReply(const ControlKey& key, const occmap::control_reply_t& reply,
                        std::vector<std::uint8_t>& buffer) {
  buffer.resize(static_cast<std::size_t>(reply.getEncodedSize()));
  reply.encode(buffer.data(), 0, static_cast<int>(buffer.size()));
  signControlMessage(key, buffer);
}

std::optional<occmap::control_reply_t> decodeControlReply(const ControlKey& key,
                                                          const std::uint8_t* data,
                                                          std::size_t size, std::string* why) {
  return decodeWalked<occmap::control_reply_t>(
      data, size, why, replyLayoutError, [&key](const std::uint8_t* bytes, std::size_t length) {
        return controlMacMatches(key, bytes, length) ? "" : "its mac does not match under the key";
      });
}

}  // namespace occmap
