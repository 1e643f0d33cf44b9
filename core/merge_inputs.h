#pragma once

#include <cstddef>
#include <optional>
#include <vector>

namespace occmap {

// What a merge node knows of its inputs, the camera PCs whose maps it merges (issue 16): each one's
// newest map, whether it is fresh, and how its clock stands against the others'. Times are passed
// in, in seconds: a map's capture time on its camera PC's clock, its arrival on the node's.
//
// Fresh: an input's newest map was captured within `max_age_s` of the newest map of any input. A
// stale input (its PC stopped, or its maps stopped coming) counts as down, and its cells turn
// unseen in the merged map; its next map makes it fresh again.
//
// Clocks: how much later an input's maps arrive than they were captured (its lag) is its clock's
// offset from the node's plus its own pipeline's latency and the network's. The least lag over the
// recent past stands for the offset plus the fastest way through; each input's clock offset
// against the others is its least lag less the smallest of all inputs' least lags (camera PCs of
// one design take about the same fastest way). Past 10 ms it is worth a warning: an offset makes
// freshness, and the moment each map shows, wrong by as much (docs/merge.md).
class MergeInputs {
 public:
  MergeInputs(std::size_t count, double max_age_s);

  std::size_t count() const { return inputs_.size(); }
  double maxAgeS() const { return max_age_s_; }

  // A map from input k, captured at `capture_s` (its clock), arrived at `arrival_s` (ours).
  void heard(std::size_t k, double capture_s, double arrival_s);

  bool heardFrom(std::size_t k) const { return inputs_[k].heard; }
  // Input k's newest map is fresh (see above); never for an input not heard from.
  bool fresh(std::size_t k) const;
  // The newest capture time of any input, if any was heard from.
  std::optional<double> newestCaptureS() const;
  // Input k's newest map's capture time.
  std::optional<double> captureS(std::size_t k) const;

  // Input k's least lag over the recent past (see above), once heard from.
  std::optional<double> leastLagS(std::size_t k) const;
  // Input k's clock offset against the other inputs (see above), once heard from.
  std::optional<double> clockOffsetS(std::size_t k) const;

  // The least lag forgets a smaller value at this rate (seconds per second of arrivals), so that it
  // follows a clock that is stepped or drifts.
  static constexpr double kLagForgetting = 1e-3;
  // A clock offset past this is warned of.
  static constexpr double kOffsetWarningS = 0.010;

 private:
  struct Input {
    bool heard = false;
    double capture_s = 0;
    double arrival_s = 0;
    double least_lag_s = 0;
  };
  std::vector<Input> inputs_;
  double max_age_s_;
};

}  // namespace occmap
