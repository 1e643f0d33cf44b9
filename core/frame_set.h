#pragma once
// When the fusion thread makes a map (ARCHITECTURE.md, "a frame set"): from the newest frame of
// each camera. After the first new frame of a set, fusion waits for the other cameras that are not
// down at most `max_wait_ns`, then fuses what it has; a camera late for a set counts with its
// previous frame while that is recent. With no new frame for `heartbeat_ns`, a map is made anyway
// (every camera down: all unseen), so that subscribers and the watchdog see the daemon alive.
//
// Time is always an argument (CLOCK_MONOTONIC ns): the rule is plain code that tests drive by hand.
// One thread (fusion) uses it; nothing here allocates after construction, locks or reads a clock.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "core/map_frame.h"

namespace occmap {

struct FrameSetPolicy {
  std::int64_t max_wait_ns = 50'000'000;  // fusion.max_wait_ms
  std::int64_t heartbeat_ns = 1'000'000'000;
};

class FrameSetAssembler {
 public:
  FrameSetAssembler(std::size_t cameras, FrameSetPolicy policy);

  // The pipeline started at `now`: the heartbeat counts from here.
  void start(std::int64_t now);
  // Camera k's newest frame is a new one, which reached the pipeline at `arrival_ns`.
  void frameArrived(std::size_t k, std::int64_t arrival_ns);
  // Whether to fuse at `now`, given each camera's state: when every camera that is not down has a
  // new frame, when the set's wait is over, at the heartbeat, or (`last_round`) at the stop, when
  // whatever is new must still make its map.
  bool shouldFuse(std::int64_t now, std::span<const CameraState> states, bool last_round) const;
  // The latest time at which shouldFuse() may turn true without a new frame (the set's deadline
  // or the heartbeat): how long the fusion thread may sleep.
  std::int64_t nextDeadline() const;
  // Whether camera k's newest frame goes into a map made at `now`: it has one, the camera is not
  // down, and the frame is no older than `recent_ns` (a late camera's previous frame counts).
  bool uses(std::size_t k, CameraState state, std::int64_t now, std::int64_t recent_ns) const;
  // A map was made at `now`: every frame held is old news, the next set opens with the next frame.
  void fused(std::int64_t now);

 private:
  struct Camera {
    std::int64_t arrival_ns = 0;  // of its newest frame
    bool held = false;            // it has delivered a frame
    bool fresh = false;           // new since the last map
  };
  FrameSetPolicy policy_;
  std::vector<Camera> cameras_;
  std::int64_t set_deadline_ns_ = 0;  // 0: no set open
  std::int64_t last_fused_ns_ = 0;
};

}  // namespace occmap
