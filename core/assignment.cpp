#include "core/assignment.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace occmap {

void Assignment::reserve(std::size_t rows, std::size_t columns) {
  const std::size_t side = std::max(rows, columns) + 1;
  square_.reserve(side * side);
  for (auto* buffer : {&row_potential_, &column_potential_, &least_}) buffer->reserve(side);
  column_row_.reserve(side);
  way_.reserve(side);
  used_.reserve(side);
  out_.reserve(side);
}

const std::vector<int>& Assignment::solve(std::span<const double> cost, std::size_t rows,
                                          std::size_t columns, double gate) {
  if (cost.size() != rows * columns) {
    throw std::invalid_argument("Assignment: the cost matrix is not rows x columns");
  }
  out_.assign(rows, -1);
  if (rows == 0 || columns == 0) return out_;
  // The method wants no more rows than columns: a tall problem is solved transposed.
  const bool transposed = rows > columns;
  const std::size_t n = transposed ? columns : rows;
  const std::size_t m = transposed ? rows : columns;
  const auto at = [&](std::size_t i, std::size_t j) {
    return transposed ? cost[j * columns + i] : cost[i * columns + j];
  };
  // A pair past the gate costs more than all the pairs within it together: the most pairs within
  // the gate first, then the least cost (what a cost of 1e6 for a gated pair does in MVDet's
  // scoring, for any size of problem).
  double within = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < m; ++j) {
      const double c = at(i, j);
      if (std::isfinite(c) && c < gate) within += std::max(0.0, c);
    }
  }
  const double dear = 2.0 * within + 1.0;
  square_.resize(n * m);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < m; ++j) {
      const double c = at(i, j);
      square_[i * m + j] = std::isfinite(c) && c < gate ? std::max(0.0, c) : dear;
    }
  }
  // Shortest augmenting paths with potentials, one row at a time; index 0 is a virtual column.
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  row_potential_.assign(n + 1, 0.0);
  column_potential_.assign(m + 1, 0.0);
  column_row_.assign(m + 1, 0);
  way_.assign(m + 1, 0);
  for (std::size_t i = 1; i <= n; ++i) {
    column_row_[0] = static_cast<int>(i);
    std::size_t j0 = 0;
    least_.assign(m + 1, kInfinity);
    used_.assign(m + 1, 0);
    do {
      used_[j0] = 1;
      const auto i0 = static_cast<std::size_t>(column_row_[j0]);
      double delta = kInfinity;
      std::size_t j1 = 0;
      for (std::size_t j = 1; j <= m; ++j) {
        if (used_[j] != 0) continue;
        const double reduced =
            square_[(i0 - 1) * m + (j - 1)] - row_potential_[i0] - column_potential_[j];
        if (reduced < least_[j]) {
          least_[j] = reduced;
          way_[j] = static_cast<int>(j0);
        }
        if (least_[j] < delta) {
          delta = least_[j];
          j1 = j;
        }
      }
      for (std::size_t j = 0; j <= m; ++j) {
        if (used_[j] != 0) {
          row_potential_[static_cast<std::size_t>(column_row_[j])] += delta;
          column_potential_[j] -= delta;
        } else {
          least_[j] -= delta;
        }
      }
      j0 = j1;
    } while (column_row_[j0] != 0);
    do {
      const auto j1 = static_cast<std::size_t>(way_[j0]);
      column_row_[j0] = column_row_[j1];
      j0 = j1;
    } while (j0 != 0);
  }
  for (std::size_t j = 1; j <= m; ++j) {
    if (column_row_[j] == 0) continue;
    const auto i = static_cast<std::size_t>(column_row_[j]) - 1;
    if (square_[i * m + (j - 1)] >= dear) continue;  // paired only because every row must be
    const std::size_t row = transposed ? j - 1 : i;
    const std::size_t column = transposed ? i : j - 1;
    out_[row] = static_cast<int>(column);
  }
  return out_;
}

}  // namespace occmap
