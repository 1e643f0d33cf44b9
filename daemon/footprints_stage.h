#pragma once
// The people on the live maps (issue 14, docs/detection.md): detection and tracking in a thread of
// their own, beside the map's path. Fusion offers each map with the changed pixels it was fused
// from (copied: the capture threads overwrite their masks); this thread takes the newest offer,
// finds the people on it (core/footprints.h), follows them (core/tracker.h) and hands the result
// to the publisher, which sends it as a tracks_t naming its map. So a detector slower than the
// cameras makes tracks at its own rate and never holds a map back, and the zones (cheap, on the
// map alone) go out with every map from the fusion thread.
// Everything is allocated before start(); a map allocates nothing once the crowd has been as
// large before.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <optional>
#include <span>
#include <vector>

#include "base/event_fd.h"
#include "core/camera.h"
#include "core/footprints.h"
#include "core/map_geometry.h"
#include "core/tracker.h"
#include "core/triple_buffer.h"
#include "daemon/pose_handover.h"

namespace occmap {

// What was found on one map.
struct FootprintsFound {
  std::uint64_t fused = 0;  // the map's number from fusion (MapFrame::fused)
  std::int64_t utime = 0;   // the map's utime
  std::vector<Detection> footprints;
  std::vector<Track> tracks;
};

class FootprintsStage {
 public:
  // `mask_bytes`: each camera's changed-pixel buffer (changedMaskBytes of its stream).
  FootprintsStage(const MapGeometry& map, std::span<const Camera> cameras,
                  const FootprintSettings& settings, std::span<const std::size_t> mask_bytes);

  // Fusion thread: the map just fused, at time_s (CLOCK_MONOTONIC seconds), and each camera's
  // changed pixels that went into it (nullptr: not used), with the generation of the camera's pose
  // they were marked under (FusionKernel's; empty: all 0). Copied; never waits.
  void offer(std::uint64_t fused, std::int64_t utime, double time_s,
             std::span<const std::uint8_t* const> changed, std::span<const CellState> cells,
             std::span<const std::uint32_t> generations = {});
  // Camera k's capture thread, once it is re-posed after a knock (core/repose.h): its pose of that
  // generation. Its masks of that generation count again once this thread has its boxes for it
  // (FootprintDetector::replaceCamera, on the first such mask); masks of another generation than
  // its boxes' say nothing. Locks briefly; a map's path takes the lock only after a re-pose.
  void reposed(std::size_t k, std::uint32_t generation, const Camera& camera);
  // Its own thread: until stop(), each newest offer in turn; after stop(), the last offer left.
  // `found` is signalled after each result is handed over (the publisher's wake-up).
  void run(const EventFd& found);
  // Any thread: run() returns once it has taken what is left.
  void stop();

  // Publisher thread: the newest result not taken yet, or nullptr.
  const FootprintsFound* takeLatest() {
    return results_.takeLatest() ? &results_.readBuffer() : nullptr;
  }
  // The fusion thread (the zones, core/zones.h): the people found on the newest map done, if it
  // was fused no more than max_age_s before time_s (else none: people move on).
  std::span<const Detection> foundFor(double time_s, double max_age_s) {
    for_zones_.takeLatest();
    const FoundForZones& found = for_zones_.readBuffer();
    if (found.time_s < time_s - max_age_s) return {};
    return found.footprints;
  }

  // One round of the thread's: the people on the newest offer, handed to takeLatest(); false when
  // there was no new offer. Public for the benchmark (bench/footprints_bench.cpp), which runs the
  // stage's work without its thread.
  bool findNewest();
  // The re-posed cameras whose boxes the detector has been given (this thread's, for tests).
  std::uint64_t reposesApplied() const { return reposes_applied_; }

 private:
  struct Offer {
    std::uint64_t fused = 0;
    std::int64_t utime = 0;
    double time_s = 0.0;
    std::vector<std::vector<std::uint8_t>> changed;
    std::vector<std::uint8_t> used;
    std::vector<std::uint32_t> generations;
    std::vector<CellState> cells;
  };
  static Offer emptyOffer(std::span<const std::size_t> mask_bytes, std::size_t cells);
  static FootprintsFound emptyResult();
  struct FoundForZones {
    double time_s = -1e300;  // the map's
    std::vector<Detection> footprints;
  };
  static FoundForZones emptyFound();

  FootprintDetector detector_;
  Tracker tracker_;
  TripleBuffer<Offer> offers_;
  TripleBuffer<FootprintsFound> results_;
  TripleBuffer<FoundForZones> for_zones_;
  std::vector<const std::uint8_t*> masks_;
  // Each camera's pose that the detector's boxes are for (0: the config's), and the re-posed ones
  // handed over by reposed() and not yet taken.
  std::vector<std::uint32_t> boxes_generation_;
  PoseHandover<Camera> reposed_;
  std::uint64_t reposes_applied_ = 0;
  // Where the tracker expects the people it follows on the next map: the detector looks there
  // first (FootprintSettings::expected_reach_m). Reserved for a crowd.
  std::vector<Eigen::Vector2d> expected_;
  double expected_within_s_;
  EventFd wakeup_;
  std::atomic<bool> stopping_{false};
};

}  // namespace occmap
