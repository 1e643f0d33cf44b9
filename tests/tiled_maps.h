#pragma once
// Maps for the tiled-map tests (map_tiles_test, tiled_map_network_test, the test publisher's
// --cells random): cells no compressor can shrink, so that every tile goes raw, at its largest.

#include <cstddef>
#include <cstdint>

#include "core/map_frame.h"
#include "map_scenes.h"

namespace occmap::testing {

// Cell `index` of random map `frame_number`: free, occupied or unseen, a third each.
inline CellState randomCell(std::int64_t frame_number, std::size_t index) {
  const double u = sceneNoise(static_cast<std::uint64_t>(frame_number), index, 0x7117);
  return static_cast<CellState>(static_cast<std::uint8_t>(u * 3.0));
}

// Fills `frame` with random map `frame_number`: its cameras, seq and utime-relative times as
// fillScene's, its cells randomCell's.
inline void fillRandom(MapFrame& frame, std::int64_t frame_number) {
  frame.seq = frame_number;
  for (std::size_t k = 0; k < frame.cameras.size(); ++k) {
    CameraContribution& camera = frame.cameras[k];
    const bool down = (frame_number + static_cast<std::int64_t>(k)) % 7 == 6;
    camera.state = down ? CameraState::kDown : CameraState::kStreaming;
    camera.used = !down;
    camera.sequence = down ? -1 : 1000 + frame_number;
    camera.capture_time_us = down ? 0 : frame.utime - 1000 * static_cast<std::int64_t>(k);
  }
  for (std::size_t i = 0; i < frame.map.cells.size(); ++i) {
    frame.map.cells[i] = randomCell(frame_number, i);
  }
}

}  // namespace occmap::testing
