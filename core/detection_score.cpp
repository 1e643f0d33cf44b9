#include "core/detection_score.h"

#include <cmath>
#include <stdexcept>

namespace occmap {

double DetectionScore::moda() const {
  if (people == 0) return 0.0;
  return 1.0 - static_cast<double>(misses() + falsePositives()) / static_cast<double>(people);
}

double DetectionScore::modp() const {
  return pairs == 0 ? 0.0 : closeness / static_cast<double>(pairs);
}

double DetectionScore::precision() const {
  return detections == 0 ? 0.0 : static_cast<double>(pairs) / static_cast<double>(detections);
}

double DetectionScore::recall() const {
  return people == 0 ? 0.0 : static_cast<double>(pairs) / static_cast<double>(people);
}

DetectionScorer::DetectionScorer(double gate_m) : gate_(gate_m) {
  if (!(gate_m > 0.0) || !std::isfinite(gate_m)) {
    throw std::invalid_argument("DetectionScorer: the gate must be a positive distance");
  }
}

const std::vector<int>& DetectionScorer::addFrame(std::span<const FloorPoint> truth,
                                                  std::span<const FloorPoint> detections) {
  distances_.resize(truth.size() * detections.size());
  for (std::size_t i = 0; i < truth.size(); ++i) {
    for (std::size_t j = 0; j < detections.size(); ++j) {
      distances_[i * detections.size() + j] =
          std::hypot(truth[i].x_m - detections[j].x_m, truth[i].y_m - detections[j].y_m);
    }
  }
  const std::vector<int>& pairs =
      assignment_.solve(distances_, truth.size(), detections.size(), gate_);
  ++score_.frames;
  score_.people += truth.size();
  score_.detections += detections.size();
  for (std::size_t i = 0; i < truth.size(); ++i) {
    if (pairs[i] < 0) continue;
    const double distance = distances_[i * detections.size() + static_cast<std::size_t>(pairs[i])];
    ++score_.pairs;
    score_.distance_m += distance;
    score_.closeness += 1.0 - distance / gate_;
  }
  return pairs;
}

}  // namespace occmap
