#pragma once
// The pixels that the people found explain, in one camera (core/footprints.h): the union of their
// boxes as disjoint rectangles of blocks, kept by bands of the image's columns so that a look at
// what a box holds costs what lies near the box, not what lies in the whole image.
//
// In a crowd of twelve on the paper's rig, each camera's union is many tens of pieces once the
// boxes follow the board (three strips each), and the detector looks at them for every candidate
// it judges, some 30 000 looks a map. People stand side by side across an image far more than
// above one another, so a look at a few bands of columns finds a few pieces each (with bands one
// narrow box wide, on sim://room-crowd: 3.4 bands, 17 pieces visited, 4.5 of them meeting the box).

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace occmap {

// Blocks [u0, u1) x [v0, v1) of a camera's image, and the pixels they cover.
struct BlockBox {
  std::uint16_t u0, v0, u1, v1;
  float pixels;
};

inline bool meet(const BlockBox& a, const BlockBox& b) {
  return a.u0 < b.u1 && b.u0 < a.u1 && a.v0 < b.v1 && b.v0 < a.v1;
}

class ExplainedPieces {
 public:
  // An image `across` blocks wide, in bands of 2^band_shift blocks; room for `room` pieces a band
  // before a band grows (it then grows once and keeps its room).
  void reset(int across, int band_shift, std::size_t room) {
    shift_ = band_shift;
    bands_.resize(
        static_cast<std::size_t>(std::max(1, across + (1 << band_shift) - 1) >> band_shift));
    for (std::vector<BlockBox>& band : bands_) {
      band.clear();
      band.reserve(room);
    }
    fragments_.reserve(room);
    cut_.reserve(room);
  }
  void clear() {
    for (std::vector<BlockBox>& band : bands_) band.clear();
  }

  // Calls visit(piece) once for each piece that meets `bound`. A piece lies in every band it
  // spans, and is visited in the first of them that `bound` spans too.
  template <class Visit>
  void forEachMeeting(const BlockBox& bound, Visit visit) const {
    if (bound.u0 >= bound.u1) return;
    const std::size_t first = bandOf(bound.u0), last = bandOf(bound.u1 - 1);
    for (std::size_t b = first; b <= last; ++b) {
      for (const BlockBox& piece : bands_[b]) {
        if (b != first && bandOf(piece.u0) != b) continue;  // visited in an earlier band
        if (meet(piece, bound)) visit(piece);
      }
    }
  }

  // The box's blocks become explained: the box less every piece already there, as at most four
  // rectangles per piece cut out of each fragment (above, below, left and right of the piece).
  void add(const BlockBox& box) {
    if (box.u0 >= box.u1 || box.v0 >= box.v1) return;
    fragments_.assign(1, box);
    forEachMeeting(box, [&](const BlockBox& piece) {
      cut_.clear();
      for (const BlockBox& f : fragments_) {
        const std::uint16_t u0 = std::max(f.u0, piece.u0), u1 = std::min(f.u1, piece.u1);
        const std::uint16_t v0 = std::max(f.v0, piece.v0), v1 = std::min(f.v1, piece.v1);
        if (u0 >= u1 || v0 >= v1) {
          cut_.push_back(f);
          continue;
        }
        if (f.v0 < v0) cut_.push_back({f.u0, f.v0, f.u1, v0, 0.0f});
        if (v1 < f.v1) cut_.push_back({f.u0, v1, f.u1, f.v1, 0.0f});
        if (f.u0 < u0) cut_.push_back({f.u0, v0, u0, v1, 0.0f});
        if (u1 < f.u1) cut_.push_back({u1, v0, f.u1, v1, 0.0f});
      }
      fragments_.swap(cut_);
    });
    for (const BlockBox& f : fragments_) {
      for (std::size_t b = bandOf(f.u0); b <= bandOf(f.u1 - 1); ++b) bands_[b].push_back(f);
    }
  }

 private:
  std::size_t bandOf(unsigned u) const { return static_cast<std::size_t>(u >> shift_); }

  int shift_ = 0;
  std::vector<std::vector<BlockBox>> bands_;
  std::vector<BlockBox> fragments_, cut_;  // add()'s
};

}  // namespace occmap
