#pragma once
// How well detections on the floor match the truth, frame by frame: the CLEAR MOD measures as
// WILDTRACK and MVDet score multi-camera people detection (Kasturi et al. 2009). In each frame the
// truth and the detections are paired by the optimal assignment (core/assignment.h) under a gate
// on the floor distance (0.5 m); a pair is a true positive, a detection left over a false
// positive, a person left over a miss. Then
//   MODA = 1 - (misses + false positives) / people,
//   MODP = the mean over pairs of 1 - distance / gate,
//   precision = pairs / detections, recall = pairs / people,
// each over all frames together. No I/O, no threads.

#include <cstddef>
#include <span>
#include <vector>

#include "core/assignment.h"

namespace occmap {

struct FloorPoint {
  double x_m = 0.0;
  double y_m = 0.0;
};

struct DetectionScore {
  std::size_t frames = 0;
  std::size_t people = 0;      // truth points
  std::size_t detections = 0;  // detected points
  std::size_t pairs = 0;       // true positives
  double closeness = 0.0;      // the sum over pairs of 1 - distance / gate
  double distance_m = 0.0;     // the sum over pairs of the distance

  std::size_t misses() const { return people - pairs; }
  std::size_t falsePositives() const { return detections - pairs; }
  // Shares (1 = 100 %); 0 where undefined (no people, no detections, no pairs).
  double moda() const;
  double modp() const;
  double precision() const;
  double recall() const;
};

class DetectionScorer {
 public:
  explicit DetectionScorer(double gate_m = 0.5);

  // One frame's truth and detections; the pairs (for each truth point its detection, or -1) are
  // returned, valid until the next call.
  const std::vector<int>& addFrame(std::span<const FloorPoint> truth,
                                   std::span<const FloorPoint> detections);

  const DetectionScore& score() const { return score_; }
  double gate() const { return gate_; }

 private:
  double gate_;
  DetectionScore score_;
  Assignment assignment_;
  std::vector<double> distances_;
};

}  // namespace occmap
