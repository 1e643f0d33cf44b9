#pragma once
// The key that control requests are signed with (docs/control.md), shared by occmapd and its
// operators. Here, below both, because the config reads it from its file (config/) and the
// messages are signed with it (transport/).

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace occmap {

// The shared key: 32 to 64 bytes (HMAC-SHA256 takes any length; 32 random bytes are as strong as
// it gets, and more than its 64-byte block would only be hashed down).
struct ControlKey {
  static constexpr std::size_t kMinBytes = 32;
  static constexpr std::size_t kMaxBytes = 64;
  ControlKey() = default;
  ControlKey(const ControlKey&) = default;
  ControlKey& operator=(const ControlKey&) = default;
  // A key leaves nothing behind in memory it no longer uses (explicit_bzero is not optimised away).
  ~ControlKey() { explicit_bzero(bytes.data(), bytes.size()); }
  std::array<std::uint8_t, kMaxBytes> bytes{};
  std::size_t size = 0;
};

}  // namespace occmap
