#include "core/track_score.h"

#include <cmath>
#include <stdexcept>

namespace occmap {

double TrackScore::mota() const {
  if (truth == 0) return 0.0;
  const double errors = static_cast<double>((truth - pairs) + (tracks - pairs) + switches);
  return 1.0 - errors / static_cast<double>(truth);
}

double TrackScore::idf1() const {
  const double denominator = static_cast<double>(truth + tracks);
  return denominator == 0 ? 0.0 : 2.0 * static_cast<double>(id_pairs) / denominator;
}

TrackScorer::TrackScorer(double gate_m) : gate_(gate_m) {
  if (!(gate_m > 0.0) || !std::isfinite(gate_m)) {
    throw std::invalid_argument("TrackScorer: the gate must be a positive distance");
  }
}

void TrackScorer::addFrame(std::span<const FloorPoint> truth,
                           std::span<const std::int64_t> truth_ids,
                           std::span<const FloorPoint> tracks,
                           std::span<const std::int64_t> track_ids) {
  if (truth.size() != truth_ids.size() || tracks.size() != track_ids.size()) {
    throw std::invalid_argument("TrackScorer: one id per point");
  }
  const auto distance = [&](std::size_t g, std::size_t t) {
    return std::hypot(truth[g].x_m - tracks[t].x_m, truth[g].y_m - tracks[t].y_m);
  };
  ++score_.frames;
  score_.truth += truth.size();
  score_.tracks += tracks.size();
  for (std::size_t g = 0; g < truth.size(); ++g) {
    ++truth_frames_[truth_ids[g]];
    for (std::size_t t = 0; t < tracks.size(); ++t) {
      if (distance(g, t) < gate_) ++together_[{truth_ids[g], track_ids[t]}];
    }
  }
  for (const std::int64_t id : track_ids) ++track_frames_[id];
  // Last frame's pairs first, where both are still there and within the gate; the rest by the
  // assignment, those two kept out of it.
  std::vector<int> pair_of(truth.size(), -1);
  std::vector<char> taken(tracks.size(), 0);
  for (std::size_t g = 0; g < truth.size(); ++g) {
    const auto last = last_.find(truth_ids[g]);
    if (last == last_.end()) continue;
    for (std::size_t t = 0; t < tracks.size(); ++t) {
      if (track_ids[t] == last->second && taken[t] == 0 && distance(g, t) < gate_) {
        pair_of[g] = static_cast<int>(t);
        taken[t] = 1;
        break;
      }
    }
  }
  cost_.assign(truth.size() * tracks.size(), gate_);
  for (std::size_t g = 0; g < truth.size(); ++g) {
    if (pair_of[g] >= 0) continue;
    for (std::size_t t = 0; t < tracks.size(); ++t) {
      if (taken[t] == 0) cost_[g * tracks.size() + t] = distance(g, t);
    }
  }
  const std::vector<int>& rest = assignment_.solve(cost_, truth.size(), tracks.size(), gate_);
  for (std::size_t g = 0; g < truth.size(); ++g) {
    if (pair_of[g] < 0) pair_of[g] = rest[g];
    if (pair_of[g] < 0) continue;
    ++score_.pairs;
    const std::int64_t track = track_ids[static_cast<std::size_t>(pair_of[g])];
    const auto [last, first_time] = last_.try_emplace(truth_ids[g], track);
    if (!first_time && last->second != track) {
      ++score_.switches;
      last->second = track;
    }
  }
}

TrackScore TrackScorer::score() const {
  TrackScore out = score_;
  // Rows: truth identities; columns: tracks, then one stand-in per truth identity (paired with
  // none). A real pair costs C - frames together, a stand-in C: the assignment, which pairs every
  // row, then maximises the frames together.
  std::vector<std::int64_t> truth_ids, track_ids;
  for (const auto& [id, frames] : truth_frames_) truth_ids.push_back(id);
  for (const auto& [id, frames] : track_frames_) track_ids.push_back(id);
  std::size_t most = 0;
  for (const auto& [ids, frames] : together_) most = std::max(most, frames);
  const double c = static_cast<double>(most) + 1.0;
  const std::size_t rows = truth_ids.size(), columns = track_ids.size() + rows;
  std::vector<double> cost(rows * columns, 2 * c);  // at the gate: no pair
  for (std::size_t g = 0; g < rows; ++g) {
    for (std::size_t t = 0; t < track_ids.size(); ++t) {
      const auto found = together_.find({truth_ids[g], track_ids[t]});
      if (found != together_.end()) {
        cost[g * columns + t] = c - static_cast<double>(found->second);
      }
    }
    cost[g * columns + track_ids.size() + g] = c;
  }
  Assignment assignment;
  const std::vector<int>& pairs = assignment.solve(cost, rows, columns, 2 * c);
  out.id_pairs = 0;
  for (std::size_t g = 0; g < rows; ++g) {
    const int t = pairs[g];
    if (t < 0 || static_cast<std::size_t>(t) >= track_ids.size()) continue;
    out.id_pairs += together_.at({truth_ids[g], track_ids[static_cast<std::size_t>(t)]});
  }
  return out;
}

}  // namespace occmap
