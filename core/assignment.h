#pragma once
// The optimal assignment of rows to columns (the Hungarian method, in the shortest augmenting path
// form of Jonker and Volgenant): the most pairs whose cost is under a gate, and among those, the
// least total cost. Matching detections to the truth when scoring (the CLEAR MOD convention of
// WILDTRACK and MVDet: a 0.5 m gate on the floor) and tracks to detections when tracking.
// No I/O, no threads; the buffers are kept between calls, so a steady size allocates nothing.

#include <cstddef>
#include <span>
#include <vector>

namespace occmap {

class Assignment {
 public:
  // `cost` is rows x columns, row-major; a pair costs at least 0, and a cost at or above `gate`
  // (or not finite) is no pair. Returns, for each row, its column, or -1 when it has none. Valid
  // until the next call.
  const std::vector<int>& solve(std::span<const double> cost, std::size_t rows, std::size_t columns,
                                double gate);
  // Room for problems up to this size, so that solving them allocates nothing.
  void reserve(std::size_t rows, std::size_t columns);

 private:
  std::vector<double> square_;  // the problem with rows <= columns, gated costs made dear
  std::vector<double> row_potential_, column_potential_, least_;
  std::vector<int> column_row_, way_;
  std::vector<char> used_;
  std::vector<int> out_;
};

}  // namespace occmap
