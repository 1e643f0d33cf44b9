#pragma once

#include <cstdint>
#include <vector>

#include "core/map_geometry.h"

namespace occmap {

// Several maps made one (issue 16: several camera PCs, one map of the whole floor), by the paper's
// own rule applied to maps as it is to cameras: a merged cell is FREE when some input frees it,
// UNSEEN when no input sees it, OCCUPIED otherwise. A camera PC's map holds, per cell, exactly
// what its cameras together decided, so merging the maps of two PCs gives the map that one PC with
// all their cameras would make.
//
// Inputs may have any geometry: each merged cell takes the input cell that holds its centre (none
// when it lies off that input's map: unseen there). An input that is down (stale, silent) is
// passed as null and counts as seeing nothing.
class MapMerger {
 public:
  MapMerger(const MapGeometry& merged, const std::vector<MapGeometry>& inputs);

  const MapGeometry& geometry() const { return merged_; }
  std::size_t inputCount() const { return inputs_.size(); }

  // `inputs[i]` is input i's map, of the geometry given for it, or null when it is down. `out` must
  // have the merged geometry. Allocates nothing.
  void merge(const std::vector<const OccupancyMap*>& inputs, OccupancyMap& out) const;

 private:
  struct Input {
    MapGeometry geometry;
    bool same = false;               // the merged geometry: cell i is cell i
    std::vector<std::int32_t> cell;  // else, per merged cell, its input cell or -1
  };

  MapGeometry merged_;
  std::vector<Input> inputs_;
};

}  // namespace occmap
