#include "core/map_merge.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace occmap {
namespace {

// For each of `count` merged cells along one axis (centres at origin + (i + 0.5) cell), the input's
// cell along it that holds that centre, or -1.
std::vector<std::int32_t> cellsAlong(double merged_origin, double merged_cell, int count,
                                     double input_origin, double input_cell, int input_count) {
  std::vector<std::int32_t> along(static_cast<std::size_t>(count), -1);
  for (int i = 0; i < count; ++i) {
    const double centre = merged_origin + (i + 0.5) * merged_cell;
    const double at = std::floor((centre - input_origin) / input_cell);
    if (at >= 0 && at < input_count)
      along[static_cast<std::size_t>(i)] = static_cast<std::int32_t>(at);
  }
  return along;
}

// The first and one past the last index holding a cell (the cells in between all do: an input's
// map is one rectangle).
void reach(const std::vector<std::int32_t>& along, int& begin, int& end) {
  begin = 0;
  while (begin < static_cast<int>(along.size()) && along[static_cast<std::size_t>(begin)] < 0) {
    ++begin;
  }
  end = begin;
  while (end < static_cast<int>(along.size()) && along[static_cast<std::size_t>(end)] >= 0) ++end;
}

}  // namespace

MapMerger::MapMerger(const MapGeometry& merged, const std::vector<MapGeometry>& inputs)
    : merged_(merged, CellState::kUnseen), counts_(merged.cellCount()) {
  if (inputs.size() > 65535) throw std::invalid_argument("MapMerger: more than 65535 inputs");
  for (const MapGeometry& geometry : inputs) inputs_.push_back(placed(geometry));
}

MapMerger::Input MapMerger::placed(const MapGeometry& geometry) const {
  const MapGeometry& merged = merged_.geometry;
  Input input;
  input.geometry = geometry;
  input.row_of = cellsAlong(merged.origin_y_m, merged.cell_size_m, merged.height,
                            geometry.origin_y_m, geometry.cell_size_m, geometry.height);
  input.column_of = cellsAlong(merged.origin_x_m, merged.cell_size_m, merged.width,
                               geometry.origin_x_m, geometry.cell_size_m, geometry.width);
  reach(input.row_of, input.rows_begin, input.rows_end);
  reach(input.column_of, input.columns_begin, input.columns_end);
  input.applied.assign(geometry.cellCount(), CellState::kUnseen);
  const auto consecutive = [](const std::vector<std::int32_t>& along, int begin, int end) {
    for (int i = begin + 1; i < end; ++i) {
      if (along[static_cast<std::size_t>(i)] != along[static_cast<std::size_t>(i - 1)] + 1) {
        return false;
      }
    }
    return true;
  };
  input.one_to_one = consecutive(input.row_of, input.rows_begin, input.rows_end) &&
                     consecutive(input.column_of, input.columns_begin, input.columns_end);
  return input;
}

void MapMerger::reshape(std::size_t k, const MapGeometry& geometry) {
  update(k, nullptr);  // its counts out of the merged map
  inputs_[k] = placed(geometry);
}

void MapMerger::update(std::size_t k, const OccupancyMap* map) {
  Input& input = inputs_[k];
  if (map != nullptr && map->cells.size() != input.geometry.cellCount()) {
    throw std::invalid_argument("MapMerger::update: input " + std::to_string(k) + "'s map has " +
                                std::to_string(map->cells.size()) + " cells, its geometry " +
                                std::to_string(input.geometry.cellCount()));
  }
  const auto width = static_cast<std::size_t>(merged_.geometry.width);
  const auto input_width = static_cast<std::size_t>(input.geometry.width);
  const auto now_at = [&](std::size_t from) {
    return map != nullptr ? map->cells[from] : CellState::kUnseen;
  };
  for (int r = input.rows_begin; r < input.rows_end; ++r) {
    const std::size_t input_row =
        static_cast<std::size_t>(input.row_of[static_cast<std::size_t>(r)]) * input_width;
    const std::size_t row = static_cast<std::size_t>(r) * width;
    if (input.one_to_one && map != nullptr) {
      // Most of a row is as it was: blocks of 64 cells compared whole, only changed ones looked in.
      constexpr int kBlock = 64;
      const std::size_t first =
          input_row +
          static_cast<std::size_t>(input.column_of[static_cast<std::size_t>(input.columns_begin)]);
      const int length = input.columns_end - input.columns_begin;
      for (int b = 0; b < length; b += kBlock) {
        const int n = std::min(kBlock, length - b);
        const std::size_t from = first + static_cast<std::size_t>(b);
        if (std::equal(map->cells.begin() + static_cast<std::ptrdiff_t>(from),
                       map->cells.begin() + static_cast<std::ptrdiff_t>(from) + n,
                       input.applied.begin() + static_cast<std::ptrdiff_t>(from))) {
          continue;
        }
        for (int j = 0; j < n; ++j) {
          const std::size_t cell = from + static_cast<std::size_t>(j);
          if (input.applied[cell] != map->cells[cell]) {
            count(row + static_cast<std::size_t>(input.columns_begin + b + j), input.applied[cell],
                  map->cells[cell]);
            input.applied[cell] = map->cells[cell];  // each input cell is read once here
          }
        }
      }
      continue;
    }
    for (int c = input.columns_begin; c < input.columns_end; ++c) {
      const std::size_t from =
          input_row + static_cast<std::size_t>(input.column_of[static_cast<std::size_t>(c)]);
      const CellState before = input.applied[from];
      const CellState now = now_at(from);
      if (before != now) count(row + static_cast<std::size_t>(c), before, now);
    }
  }
  // A merged cell finer than the input's reads an input cell more than once: the cells counted are
  // recorded after the whole pass (one to one, they were as they went; cells beyond the merged
  // map's reach are never counted, so they may stay as they were).
  if (input.one_to_one && map != nullptr) return;
  if (map != nullptr) {
    std::copy(map->cells.begin(), map->cells.end(), input.applied.begin());
  } else {
    std::fill(input.applied.begin(), input.applied.end(), CellState::kUnseen);
  }
}

void MapMerger::count(std::size_t i, CellState before, CellState now) {
  Counts& c = counts_[i];
  c.frees = static_cast<std::uint16_t>(c.frees + (now == CellState::kFree) -
                                       (before == CellState::kFree));
  c.sees = static_cast<std::uint16_t>(c.sees + (now != CellState::kUnseen) -
                                      (before != CellState::kUnseen));
  merged_.cells[i] = c.frees > 0  ? CellState::kFree
                     : c.sees > 0 ? CellState::kOccupied
                                  : CellState::kUnseen;
}

void MapMerger::merge(const std::vector<const OccupancyMap*>& inputs, OccupancyMap& out) {
  if (inputs.size() != inputs_.size() || out.cells.size() != merged_.cells.size()) {
    throw std::invalid_argument("MapMerger::merge: " + std::to_string(inputs.size()) +
                                " maps for " + std::to_string(inputs_.size()) +
                                " inputs, or an output of another geometry");
  }
  for (std::size_t k = 0; k < inputs.size(); ++k) update(k, inputs[k]);
  std::copy(merged_.cells.begin(), merged_.cells.end(), out.cells.begin());
}

}  // namespace occmap
