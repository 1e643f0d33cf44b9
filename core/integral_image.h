#pragma once
// Sums over rectangles of an integral image: the detector's changed pixels per camera and
// occupied cells of the map (core/footprints.h).

#include <cstddef>
#include <cstdint>
#include <vector>

namespace occmap {

// Sum over [u0, u1) x [v0, v1) of an image whose integral image (one row and one column of
// zeros first) is `integral`, of width + 1 entries a row.
inline std::uint32_t rectangleSum(const std::vector<std::uint32_t>& integral, int width, int u0,
                                  int v0, int u1, int v1) {
  const auto at = [&](int u, int v) {
    return integral[static_cast<std::size_t>(v) * static_cast<std::size_t>(width + 1) +
                    static_cast<std::size_t>(u)];
  };
  return at(u1, v1) - at(u0, v1) - at(u1, v0) + at(u0, v0);
}

}  // namespace occmap
