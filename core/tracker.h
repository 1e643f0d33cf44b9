#pragma once
// People followed from map to map (issue 14, docs/detection.md): tracking in the map's space, as
// the paper's future work has it, where "the object of interest maintains a constant size" and no
// hand-over between cameras is needed.
// Each track is a constant-velocity Kalman filter on the floor (state x, y, vx, vy; white
// acceleration noise); each map's detections are given to the predicted tracks by the optimal
// assignment (core/assignment.h) under a gate, the confirmed tracks first and the tentative ones
// from the detections left; a detection given to no track starts a tentative
// one, which is confirmed after `confirm_hits` detections within `confirm_within_s`; a track that
// gets no detection coasts on its velocity and is ended after `lost_after_s` (two seconds: a
// person hidden behind another for that long keeps their identity). A detection held where the
// track was expected (Detection::held) moves a confirmed track on but does not count as seeing
// it: a track only held ends as one with none, lost_after_s after it was last found.
// Time is passed in with each map: no clock is read, so the tests need not sleep. No I/O, no
// threads; nothing is allocated per map once the track count has been reached.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "core/assignment.h"
#include "core/footprints.h"

namespace occmap {

struct TrackerSettings {
  double gate_m = 0.75;  // the farthest a detection may be from a track's prediction
  // A detection's error, standard deviation on each axis: as measured, the root mean square of
  // the detections' errors within the 0.5 m gate, 0.10-0.11 m on sim://room-crowd and three other
  // crowds (heavy-tailed: 0.06-0.07 m from the median). It was 0.15 m, a guess, and the filter
  // trusted each detection too little: its tracks stood farther from the people than the
  // detections did (crowd 1: median 0.102 m against 0.066; with 0.10, 0.081). Over ten crowds
  // never measured on (sim://room-crowd-1..10, docs/detection.md): MOTA 84.2 -> 84.9 %, IDF1
  // 64.4 -> 69.0 % at the mean (the first five, where 0.07, 0.10, 0.12 and 0.15 were tried:
  // IDF1 63.2, 66.8, 64.3 and 63.2 %; the other five, looked at only for 0.10 against 0.15: MOTA up
  // on each, IDF1 up on four); sim://room-crowd MOTA 90.5 -> 92.0 %, IDF1 70.5 -> 74.7 %; the
  // room's MOTA 96.4 -> 96.9 %, IDF1 98.2 -> 98.1 %.
  double position_noise_m = 0.10;
  double acceleration_m_s2 = 2.0;  // how fast people change their velocity, standard deviation
  int confirm_hits = 3;            // detections before a track is reported
  double confirm_within_s = 1.0;   // ... within this long of its first
  double lost_after_s = 2.0;       // a track with no detection for this long ends
  // A tentative track this near a track confirmed on an earlier map is not confirmed: two
  // footprints a person's box wide (FootprintSettings::box_width_m) do not overlap, so it is the
  // same person or thing found twice (a chair wider than the box, found again beside itself).
  // Two people who appear together are both confirmed, however near. 0: no such rule. Measured over
  // 600 maps with the tracker's order (docs/detection.md): sim://room MOTA 94.6 -> 96.8 %, IDF1
  // 89.7 -> 98.4 %; sim://room-crowd MOTA 73.5 -> 74.7 %, IDF1 41.0 -> 49.3 %.
  double confirm_apart_m = 0.5;
  // A track with no detection on this map is kept (its identity waits for the person to come out
  // from behind someone) but reported only while it has missed no more than this many maps in a
  // row: where it coasts is a guess. A person hidden but known to be there is held by the
  // detector (FootprintSettings::hold_hidden) and counts as a detection. With holds, over
  // sim://room-crowd's 600 maps (30 a second), MOTA 91.0 / 90.5 / 89.1 / 87.5 % reporting tracks
  // unseen for 0 maps / 1 map / 0.1 s / 0.2 s (identity switches 109 / 59 / 55 / 47; the room 96.2
  // / 96.4 / 97.0 / 97.3 %). Without holds, on its first 300 maps, 0 / 0.2 / 0.5 / 2 s gave 59 /
  // 63 / 57 / 40 % (docs/detection.md).
  int reported_missed_maps = 1;
};

struct Track {
  std::uint32_t id = 0;  // from 1, never reused
  double x_m = 0.0, y_m = 0.0;
  double vx_m_s = 0.0, vy_m_s = 0.0;
  double area_m2 = 0.0;  // the last detection's
  double age_s = 0.0;    // since its first detection
  // Since the evidence last found it (0: found on this map); it grows while the track is held.
  double unseen_s = 0.0;
  bool confirmed = false;
};

class Tracker {
 public:
  explicit Tracker(const TrackerSettings& settings = {});

  // One map's detections, taken at time_s (seconds, any origin, not decreasing). Returns the
  // confirmed tracks, valid until the next call.
  const std::vector<Track>& update(std::span<const Detection> detections, double time_s);

  // Where the people followed should stand at time_s (no earlier than the last update): each
  // confirmed track found no more than within_s before time_s, moved on at its velocity. The
  // detector looks for them there first (FootprintDetector::detect's `expected`). Appends to out.
  void expectedAt(double time_s, double within_s, std::vector<Eigen::Vector2d>& out) const;

 private:
  struct State {
    Track track;
    Eigen::Vector4d x;     // x, y, vx, vy
    Eigen::Matrix4d p;     // its covariance
    double first_s = 0.0;  // first detection
    double last_s = 0.0;   // last detection
    double seen_s = 0.0;   // last detection found by the evidence alone (not held)
    int missed = 0;        // maps in a row without a detection
    int hits = 0;
  };
  void predict(State& state, double dt) const;
  void correct(State& state, const Detection& detection, double time_s) const;

  TrackerSettings settings_;
  std::vector<State> states_;
  std::vector<Track> out_;
  std::vector<double> cost_;
  std::vector<double> tier_cost_;  // cost_ for one tier of tracks, the others no pair
  std::vector<char> used_;
  Assignment assignment_;
  std::uint32_t next_id_ = 1;
  double time_s_ = 0.0;
  bool started_ = false;
};

}  // namespace occmap
