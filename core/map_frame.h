#pragma once

#include <cstdint>
#include <vector>

#include "core/map_geometry.h"
#include "core/zones.h"

namespace occmap {

// A camera as the pipeline sees it.
enum class CameraState : std::uint8_t {
  kStarting = 0,   // opened, no frame yet
  kStreaming = 1,  // delivering frames
  kDown = 2,       // stopped delivering or lost: its cells count as unseen
};

// One camera's part in a map frame (occmap.camera_frame_t on the wire).
struct CameraContribution {
  CameraState state = CameraState::kStarting;
  bool used = false;                 // one of its frames went into this map
  std::int64_t sequence = -1;        // that frame's number from its source, -1 when not used
  std::int64_t capture_time_us = 0;  // that frame's host capture time, 0 when not used
};

// One fused map with what went into it (occmap.map_frame_t on the wire). Allocated once per
// pipeline and reused: the fusion thread fills one while the publisher sends another.
struct MapFrame {
  // Numbered by the publisher as it sends, so that a gap a subscriber sees is a map lost on the way
  // (fusion may make maps faster than they are sent; those are skipped, not lost).
  std::int64_t seq = 0;
  std::int64_t utime = 0;  // host capture time of the newest fused frame, us since the Unix epoch
  // When the newest fused frame reached the pipeline (CLOCK_MONOTONIC ns; 0 when none was fused),
  // for the publisher to measure what the daemon adds to a frame's way (not sent).
  std::int64_t newest_arrival_ns = 0;
  // The fusion's number of this map (from 0, +1 per map fused, published or not) and its time
  // (CLOCK_MONOTONIC, seconds), for the tracks found on it later (not sent).
  std::uint64_t fused = 0;
  double time_s = 0.0;
  OccupancyMap map;
  std::vector<CameraContribution> cameras;
  std::vector<ZoneStatus> zones;  // each zone of the config on this map (zones_t)

  MapFrame(const MapGeometry& geometry, std::size_t camera_count, std::size_t zone_count = 0)
      : map(geometry), cameras(camera_count), zones(zone_count) {}
};

}  // namespace occmap
