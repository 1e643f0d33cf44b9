#pragma once
// LCM's wire format read field by field, never past the end: what the decoders of messages from
// the network (map_codec.cpp, status_message.cpp) walk a message with, checking every count against
// the bytes received before LCM's generated decoder (which trusts the counts) sees it.

#include <bit>
#include <climits>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <exception>
#include <optional>
#include <string>
#include <type_traits>

namespace occmap {

class WireReader {
 public:
  WireReader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  std::size_t position() const { return position_; }
  std::size_t remaining() const { return size_ - position_; }

  // One big-endian field; false (and nothing read) when the message ends before it.
  template <typename T>
  bool read(T& value) {
    static_assert(std::is_arithmetic_v<T>);
    if (remaining() < sizeof(T)) return false;
    std::uint64_t bits = 0;
    for (std::size_t i = 0; i < sizeof(T); ++i) bits = bits << 8 | data_[position_ + i];
    position_ += sizeof(T);
    if constexpr (sizeof(T) == 8) {
      value = std::bit_cast<T>(bits);
    } else if constexpr (sizeof(T) == 4) {
      value = std::bit_cast<T>(static_cast<std::uint32_t>(bits));
    } else if constexpr (sizeof(T) == 2) {
      value = std::bit_cast<T>(static_cast<std::uint16_t>(bits));
    } else {
      value = std::bit_cast<T>(static_cast<std::uint8_t>(bits));
    }
    return true;
  }
  bool skip(std::size_t bytes) {
    if (remaining() < bytes) return false;
    position_ += bytes;
    return true;
  }

  // An LCM string: an int32 length that counts the terminating NUL, the bytes, the NUL. False when
  // the length is below 1 or past the end, the last byte is not NUL, or a NUL comes before it (no
  // LCM encoder can send that: they all take the length up to the first NUL, so a decoder that
  // kept it would read a text that no one wrote); `text` then points nowhere.
  bool readString(const char*& text, std::size_t& length) {
    std::int32_t size = 0;
    if (!read(size)) return false;
    if (size < 1 || static_cast<std::size_t>(size) > remaining()) return false;
    const std::size_t bytes = static_cast<std::size_t>(size);
    if (data_[position_ + bytes - 1] != 0) return false;
    if (std::memchr(data_ + position_, 0, bytes - 1) != nullptr) return false;
    text = reinterpret_cast<const char*>(data_ + position_);
    length = bytes - 1;
    position_ += bytes;
    return true;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t position_ = 0;
};

// A message from the network decoded by LCM's generated decoder, but only once `problems` (the
// walk with a WireReader, then any further check such as a mac) have found nothing: each returns
// "" or why the bytes are refused. Then every count agrees with `size`, so the decoder allocates
// no more than the message holds. Nothing when refused, and `error`, if given, says why; no
// exception leaves.
template <typename Message, typename... Problems>
std::optional<Message> decodeWalked(const std::uint8_t* data, std::size_t size, std::string* error,
                                    Problems... problems) {
  auto refuse = [error](const char* why) -> std::optional<Message> {
    if (error != nullptr) *error = why;
    return std::nullopt;
  };
  if (data == nullptr) return refuse("no data");
  if (size > static_cast<std::size_t>(INT_MAX)) return refuse("larger than LCM allows");
  const char* why = "";
  // In order, stopping at the first problem.
  (void)((*(why = problems(data, size)) == '\0') && ...);
  if (*why != '\0') return refuse(why);
  Message message{};
  try {
    if (message.decode(data, 0, static_cast<int>(size)) != static_cast<int>(size)) {
      return refuse("LCM's decoder did not take the whole message");
    }
  } catch (const std::exception&) {
    return refuse("out of memory while decoding");
  }
  return message;
}

}  // namespace occmap
