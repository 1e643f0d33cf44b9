#pragma once
// How well tracks follow the truth's identities: MOTA (CLEAR MOT, Bernardin & Stiefelhagen 2008)
// and IDF1 (Ristani et al. 2016), with the floor distance and gate of core/detection_score.h.
// - MOTA = 1 - (misses + false positives + identity switches) / truth points. In each frame the
//   last frame's pairs are kept while both are still there and within the gate, the rest paired by
//   the optimal assignment; a truth identity paired with another track than the last it was paired
//   with is a switch.
// - IDF1 = 2 IDTP / (2 IDTP + IDFP + IDFN): identities paired once for the whole sequence, each
//   truth identity with the track that shares the most frames within the gate with it (the
//   assignment maximising those frames); IDTP counts them.
// No I/O, no threads.

#include <cstddef>
#include <cstdint>
#include <map>
#include <span>
#include <utility>
#include <vector>

#include "core/assignment.h"
#include "core/detection_score.h"

namespace occmap {

struct TrackScore {
  std::size_t frames = 0;
  std::size_t truth = 0;   // truth points
  std::size_t tracks = 0;  // track points
  std::size_t pairs = 0;
  std::size_t switches = 0;
  std::size_t id_pairs = 0;  // IDTP
  double mota() const;
  double idf1() const;
};

class TrackScorer {
 public:
  explicit TrackScorer(double gate_m = 0.5);
  void addFrame(std::span<const FloorPoint> truth, std::span<const std::int64_t> truth_ids,
                std::span<const FloorPoint> tracks, std::span<const std::int64_t> track_ids);
  // The scores so far (IDF1's global pairing is made here).
  TrackScore score() const;

 private:
  double gate_;
  TrackScore score_;
  Assignment assignment_;
  std::vector<double> cost_;
  std::map<std::int64_t, std::int64_t> last_;  // truth id -> the track it was last paired with
  std::map<std::pair<std::int64_t, std::int64_t>, std::size_t> together_;  // frames within gate
  std::map<std::int64_t, std::size_t> truth_frames_, track_frames_;
};

}  // namespace occmap
