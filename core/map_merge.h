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
// given as null and counts as seeing nothing.
//
// The merged map is kept up to date input by input: each merged cell counts the inputs that free
// it and those that see it, and an input's new map changes the counts only where that input
// reaches and its cells changed. So a merge node of 16 camera PCs does a sixteenth of the merged
// map's work per map heard, not all of it (bench/merge_bench.cpp).
class MapMerger {
 public:
  MapMerger(const MapGeometry& merged, const std::vector<MapGeometry>& inputs);

  const MapGeometry& geometry() const { return merged_.geometry; }
  std::size_t inputCount() const { return inputs_.size(); }
  const MapGeometry& inputGeometry(std::size_t k) const { return inputs_[k].geometry; }

  // Input k's newest map (of the geometry given for it), or null when it is down: the merged map
  // follows where input k reaches. Allocates nothing. Throws std::invalid_argument for a map of
  // another size.
  void update(std::size_t k, const OccupancyMap* map);
  const OccupancyMap& merged() const { return merged_; }
  // Input k's maps have another geometry from now on (a camera PC first heard, or reconfigured):
  // it counts as down until its next update(). Only input k's part is redone, so a node that
  // hears its PCs one by one at start does not merge everything again for each (allocates).
  void reshape(std::size_t k, const MapGeometry& geometry);

  // Every input at once (`inputs[k]` as for update), the merged map copied to `out`.
  void merge(const std::vector<const OccupancyMap*>& inputs, OccupancyMap& out);

 private:
  struct Input {
    MapGeometry geometry;
    // Per merged row and column, the input's row and column under its centre, or -1.
    std::vector<std::int32_t> row_of;
    std::vector<std::int32_t> column_of;
    int rows_begin = 0, rows_end = 0, columns_begin = 0, columns_end = 0;  // where it reaches
    // Its cells are the merged cells where it reaches, one for one (the same cell size, on the same
    // grid): a row of it is a run of merged cells, compared a block at a time.
    bool one_to_one = false;
    std::vector<CellState> applied;  // the cells last counted (unseen: nothing)
  };

  Input placed(const MapGeometry& geometry) const;
  // Counts merged cell i anew for input cell `from` going from `before` to `now`.
  void count(std::size_t i, CellState before, CellState now);

  OccupancyMap merged_;
  // Per merged cell, the inputs that free it and those that see it (free or occupied), side by
  // side: a changed cell costs one cache line, not two (bench/merge_bench.cpp).
  struct Counts {
    std::uint16_t frees = 0;
    std::uint16_t sees = 0;
  };
  std::vector<Counts> counts_;
  std::vector<Input> inputs_;
};

}  // namespace occmap
