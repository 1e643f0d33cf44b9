#include "core/footprint_merge.h"

#include <algorithm>

namespace occmap {

FootprintMerger::FootprintMerger(double gate_m) : gate_m_(gate_m) {}

bool FootprintMerger::joinable(std::size_t a, std::size_t b) const {
  // No two footprints of one input in a cluster.
  for (std::size_t i : clusters_[a]) {
    for (std::size_t j : clusters_[b]) {
      if (members_[i].input == members_[j].input) return false;
    }
  }
  return true;
}

const std::vector<Detection>& FootprintMerger::merge(
    std::span<const std::span<const Detection>> found) {
  members_.clear();
  for (std::size_t k = 0; k < found.size(); ++k) {
    for (const Detection& footprint : found[k]) {
      members_.push_back({footprint, k, members_.size()});
    }
  }
  if (clusters_.size() < members_.size()) clusters_.resize(members_.size());
  for (std::size_t i = 0; i < members_.size(); ++i) {
    clusters_[i].clear();
    clusters_[i].push_back(i);
  }
  pairs_.clear();
  const double gate2 = gate_m_ * gate_m_;
  for (std::size_t i = 0; i < members_.size(); ++i) {
    for (std::size_t j = i + 1; j < members_.size(); ++j) {
      if (members_[i].input == members_[j].input) continue;
      const double dx = members_[i].footprint.x_m - members_[j].footprint.x_m;
      const double dy = members_[i].footprint.y_m - members_[j].footprint.y_m;
      const double d2 = dx * dx + dy * dy;
      if (d2 <= gate2) pairs_.push_back({d2, i, j});
    }
  }
  std::sort(pairs_.begin(), pairs_.end(), [](const Pair& p, const Pair& q) {
    return p.distance2 < q.distance2 ||
           (p.distance2 == q.distance2 && (p.a < q.a || (p.a == q.a && p.b < q.b)));
  });
  for (const Pair& pair : pairs_) {
    const std::size_t a = members_[pair.a].cluster, b = members_[pair.b].cluster;
    if (a == b || !joinable(a, b)) continue;
    for (std::size_t m : clusters_[b]) {
      members_[m].cluster = a;
      clusters_[a].push_back(m);
    }
    clusters_[b].clear();
  }
  merged_.clear();
  for (std::size_t c = 0; c < members_.size(); ++c) {
    if (clusters_[c].empty()) continue;
    Detection one;
    double weight = 0.0;
    for (std::size_t m : clusters_[c]) {
      const Detection& d = members_[m].footprint;
      // A footprint scored 0 still has a place: the least weight, not none.
      const double w = std::max(d.score, 1e-3);
      one.x_m += w * d.x_m;
      one.y_m += w * d.y_m;
      weight += w;
      one.area_m2 = std::max(one.area_m2, d.area_m2);
      one.score = std::max(one.score, d.score);
      one.height_m = std::max(one.height_m, d.height_m);
    }
    one.x_m /= weight;
    one.y_m /= weight;
    merged_.push_back(one);
  }
  return merged_;
}

}  // namespace occmap
