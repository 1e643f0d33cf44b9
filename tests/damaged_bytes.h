#pragma once
// A message damaged as a network or a hostile sender could: one to four bytes set at random, bits
// flipped, or the message cut short, for the decoders' tests (map_codec_test, map_tiles_test).
#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

namespace occmap::testing {

inline void damageBytes(std::vector<std::uint8_t>& bytes, std::mt19937& rng) {
  const int damage = 1 + static_cast<int>(rng() % 4);
  for (int d = 0; d < damage; ++d) {
    const std::size_t at = rng() % bytes.size();
    switch (rng() % 3) {
      case 0:
        bytes[at] = static_cast<std::uint8_t>(rng());
        break;
      case 1:
        bytes[at] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
        break;
      default:
        bytes.resize(at);
        if (bytes.empty()) bytes.push_back(0);
    }
  }
}

}  // namespace occmap::testing
