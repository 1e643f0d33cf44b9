#pragma once
// How the map_tile target's input is cut into messages (fuzz/map_tile_target.cpp), and how
// fuzz_make_seeds writes its seeds: one input is several messages, so that the tile assembler sees
// tiles of several maps, out of order, copied, lost, late, with hostile bytes among them. Each
// message is
//   a header byte: bit 0 (kOnMapChannel) sends it on the map channel, as a whole map_frame_t,
//                  instead of the tiles channel; bit 1 (kFlushAfter) flushes the receiver after
//                  it, as when the stream stops; the other bits mean nothing,
//   its length, a big-endian uint16 (a tile message is at most 61440 bytes),
//   its bytes; the last message takes what is left when its length says more.
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <vector>

#include "fuzz/fuzz_target.h"

namespace occmap::fuzz {

inline constexpr std::uint8_t kOnMapChannel = 1;
inline constexpr std::uint8_t kFlushAfter = 2;

struct TileInputMessage {
  std::uint8_t header = 0;
  Input bytes;
};

// The messages of `input`, in order. `whole` is set to whether the input is exactly messages: no
// length that says more than is left, no bytes after the last one.
inline std::vector<TileInputMessage> splitTileInput(Input input, bool& whole) {
  std::vector<TileInputMessage> messages;
  std::size_t at = 0;
  whole = true;
  while (input.size() - at >= 3) {
    const std::uint8_t header = input[at];
    const std::size_t length = static_cast<std::size_t>(input[at + 1]) << 8 | input[at + 2];
    at += 3;
    const std::size_t taken = length <= input.size() - at ? length : input.size() - at;
    if (taken != length) whole = false;
    messages.push_back({header, input.subspan(at, taken)});
    at += taken;
  }
  if (at != input.size()) whole = false;
  return messages;
}

// Appends one message to an input being written (fuzz_make_seeds). Throws std::length_error for a
// message of more than 65535 bytes, which no length can say.
inline void appendTileInput(std::vector<std::uint8_t>& input, std::span<const std::uint8_t> bytes,
                            std::uint8_t header = 0) {
  if (bytes.size() > 0xffff) throw std::length_error("a map_tile input message over 65535 bytes");
  input.push_back(header);
  input.push_back(static_cast<std::uint8_t>(bytes.size() >> 8));
  input.push_back(static_cast<std::uint8_t>(bytes.size()));
  input.insert(input.end(), bytes.begin(), bytes.end());
}

}  // namespace occmap::fuzz
