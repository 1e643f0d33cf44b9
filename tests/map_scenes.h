#pragma once
// Map frames that look like occmapd's, for the transport tests and the test publisher: a room of
// free floor with a ragged edge where the cameras' views end, unseen outside it, furniture, people
// who walk with the frame number, the floor hidden behind them from a camera (occupied wedges), and
// a sprinkle of single occupied cells (sensor noise).

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/map_frame.h"

namespace occmap::testing {

// A deterministic hash of (a, b, c) into [0, 1).
inline double sceneNoise(std::uint64_t a, std::uint64_t b, std::uint64_t c) {
  std::uint64_t x =
      a * 0x9E3779B97F4A7C15ull ^ b * 0xC2B2AE3D27D4EB4Full ^ c * 0x165667B19E3779F9ull;
  x ^= x >> 33;
  x *= 0xFF51AFD7ED558CCDull;
  x ^= x >> 33;
  return static_cast<double>(x >> 11) / 9007199254740992.0;
}

inline std::vector<std::string> sceneCameraNames(std::size_t count) {
  std::vector<std::string> names;
  for (std::size_t k = 0; k < count; ++k) names.push_back("c" + std::to_string(k));
  return names;
}

// Fills `frame` with scene `frame_number` (frame.map.geometry sets the size; any size works, the
// scene scales with it). Camera k is down in frames where (frame_number + k) % 7 == 6.
inline void fillScene(MapFrame& frame, std::int64_t frame_number) {
  const MapGeometry& g = frame.map.geometry;
  const double w = g.width, h = g.height;
  const double t = static_cast<double>(frame_number);
  struct Blob {
    double x, y, rx, ry;  // centre and radii, in cells
    // The floor hidden behind the blob from every camera: a short wedge within the blob's angular
    // width as seen from one camera, from its centre out to three radii further.
    double ux = 0, uy = 0, distance = 0, spread = 0, reach = 0;
  };
  std::vector<Blob> blobs = {
      {0.30 * w, 0.70 * h, 0.05 * w, 0.03 * h},  // a table
      {0.75 * w, 0.25 * h, 0.04 * w, 0.06 * h},  // a cupboard
  };
  for (int p = 0; p < 4; ++p) {  // people, walking on ellipses a quarter turn apart
    const double phase = 0.05 * t + 1.5707963 * p;
    blobs.push_back({(0.55 + 0.28 * std::cos(phase)) * w, (0.5 + 0.25 * std::sin(1.3 * phase)) * h,
                     0.018 * w, 0.018 * h});
  }
  const double camera_x = 0.05 * w, camera_y = 0.5 * h;
  for (Blob& b : blobs) {
    b.distance = std::hypot(b.x - camera_x, b.y - camera_y);
    b.ux = (b.x - camera_x) / b.distance;
    b.uy = (b.y - camera_y) / b.distance;
    b.spread = std::max(b.rx, b.ry) / b.distance;
    b.reach = b.distance + 3 * std::max(b.rx, b.ry);
  }
  for (int row = 0; row < g.height; ++row) {
    // The room, with the ragged edge of the cameras' views.
    const double ragged = 3.0 * sceneNoise(static_cast<std::uint64_t>(row), 1, 0);
    for (int column = 0; column < g.width; ++column) {
      const double x = column + 0.5, y = row + 0.5;
      const double edge = ragged + 3.0 * sceneNoise(static_cast<std::uint64_t>(column), 2, 0);
      CellState state = CellState::kFree;
      if (x < 0.08 * w + edge || x > 0.92 * w - edge || y < 0.12 * h + edge ||
          y > 0.88 * h - edge) {
        state = CellState::kUnseen;
      } else {
        const double px = x - camera_x, py = y - camera_y;
        for (const Blob& b : blobs) {
          const double dx = (x - b.x) / b.rx, dy = (y - b.y) / b.ry;
          const double along = px * b.ux + py * b.uy;
          if (dx * dx + dy * dy <= 1.0 || (along > b.distance && along < b.reach &&
                                           std::fabs(px * b.uy - py * b.ux) < b.spread * along)) {
            state = CellState::kOccupied;
            break;
          }
        }
        if (state == CellState::kFree &&
            sceneNoise(static_cast<std::uint64_t>(row), static_cast<std::uint64_t>(column),
                       static_cast<std::uint64_t>(frame_number) + 7) < 0.001) {
          state = CellState::kOccupied;
        }
      }
      frame.map.cells[static_cast<std::size_t>(g.index(row, column))] = state;
    }
  }
  frame.seq = frame_number;
  for (std::size_t k = 0; k < frame.cameras.size(); ++k) {
    CameraContribution& camera = frame.cameras[k];
    const bool down = (frame_number + static_cast<std::int64_t>(k)) % 7 == 6;
    camera.state = down ? CameraState::kDown : CameraState::kStreaming;
    camera.used = !down;
    camera.sequence = down ? -1 : 1000 + frame_number;
    camera.capture_time_us = down ? 0 : frame.utime - 1000 * static_cast<std::int64_t>(k);
  }
}

// The shares of free, occupied and unseen cells.
struct CellShares {
  double free = 0, occupied = 0, unseen = 0;
};
inline CellShares cellShares(const std::vector<CellState>& cells) {
  CellShares shares;
  for (const CellState c : cells) {
    (c == CellState::kFree       ? shares.free
     : c == CellState::kOccupied ? shares.occupied
                                 : shares.unseen) += 1;
  }
  const double n = static_cast<double>(cells.size());
  shares.free /= n;
  shares.occupied /= n;
  shares.unseen /= n;
  return shares;
}

}  // namespace occmap::testing
