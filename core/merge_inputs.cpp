#include "core/merge_inputs.h"

#include <algorithm>

namespace occmap {

MergeInputs::MergeInputs(std::size_t count, double max_age_s)
    : inputs_(count), max_age_s_(max_age_s) {}

void MergeInputs::heard(std::size_t k, double capture_s, double arrival_s) {
  Input& input = inputs_[k];
  const double lag = arrival_s - capture_s;
  if (!input.heard) {
    input.least_lag_s = lag;
  } else {
    // A map that comes late is no news about the clock; one that comes early is.
    const double forgotten =
        input.least_lag_s + kLagForgetting * std::max(0.0, arrival_s - input.arrival_s);
    input.least_lag_s = std::min(lag, forgotten);
  }
  // A map older than the one held (reordered on the way) does not replace it.
  if (!input.heard || capture_s >= input.capture_s) input.capture_s = capture_s;
  input.arrival_s = std::max(input.arrival_s, arrival_s);
  input.heard = true;
}

std::optional<double> MergeInputs::newestCaptureS() const {
  std::optional<double> newest;
  for (const Input& input : inputs_) {
    if (input.heard && (!newest || input.capture_s > *newest)) newest = input.capture_s;
  }
  return newest;
}

std::optional<double> MergeInputs::captureS(std::size_t k) const {
  if (!inputs_[k].heard) return std::nullopt;
  return inputs_[k].capture_s;
}

bool MergeInputs::fresh(std::size_t k) const {
  const Input& input = inputs_[k];
  const std::optional<double> newest = newestCaptureS();
  return input.heard && newest && *newest - input.capture_s <= max_age_s_;
}

std::optional<double> MergeInputs::leastLagS(std::size_t k) const {
  if (!inputs_[k].heard) return std::nullopt;
  return inputs_[k].least_lag_s;
}

std::optional<double> MergeInputs::clockOffsetS(std::size_t k) const {
  if (!inputs_[k].heard) return std::nullopt;
  double smallest = inputs_[k].least_lag_s;
  for (const Input& input : inputs_) {
    if (input.heard) smallest = std::min(smallest, input.least_lag_s);
  }
  return inputs_[k].least_lag_s - smallest;
}

}  // namespace occmap
