#pragma once
// The people found by several camera PCs made one list (issue 16: tracks on the merged map). Each
// PC's occmapd finds people with its own cameras' pixels (core/footprints.h) and sends them with
// its map; a merge node has only the maps, and a map alone cannot tell a person from the floor
// hidden behind one (docs/detection.md). So the merge node merges the PCs' findings, not their
// pixels: a person where two PCs' views overlap is found by both, a few centimetres apart, and is
// one person on the merged map.
//
// Footprints of different inputs nearer than the gate are the same person, nearest pairs first;
// one input's footprints are never joined (its own detector already told them apart), so a cluster
// holds at most one footprint per input. A cluster is one footprint at the score-weighted mean of
// its members' places, with the largest area, score and height among them. No I/O, no threads; no
// allocation once the vectors have reached the crowd's size.

#include <cstddef>
#include <span>
#include <vector>

#include "core/footprints.h"

namespace occmap {

class FootprintMerger {
 public:
  // gate_m: the farthest apart two PCs' footprints of one person are taken to be. Less than two
  // people's shoulder to shoulder distance (about 0.5 m), more than two PCs' disagreement about
  // one person (centimetres when their calibrations agree).
  explicit FootprintMerger(double gate_m = 0.35);

  // Input k's footprints in `found[k]` (empty: none, or nothing new from it). The merged list,
  // valid until the next call.
  const std::vector<Detection>& merge(std::span<const std::span<const Detection>> found);

 private:
  struct Member {
    Detection footprint;
    std::size_t input = 0;
    std::size_t cluster = 0;
  };
  struct Pair {
    double distance2 = 0.0;
    std::size_t a = 0, b = 0;
  };
  bool joinable(std::size_t a, std::size_t b) const;

  double gate_m_;
  std::vector<Member> members_;
  std::vector<Pair> pairs_;
  std::vector<std::vector<std::size_t>> clusters_;  // members by cluster (empty once joined)
  std::vector<Detection> merged_;
};

}  // namespace occmap
