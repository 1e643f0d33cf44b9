#include "core/map_geometry.h"

#include <cmath>

namespace occmap {

std::optional<int> MapGeometry::cellAt(double x, double y) const {
  const double column = std::floor((x - origin_x_m) / cell_size_m);
  const double row = std::floor((y - origin_y_m) / cell_size_m);
  if (!(column >= 0 && row >= 0 && column < width && row < height)) return std::nullopt;
  return index(static_cast<int>(row), static_cast<int>(column));
}

}  // namespace occmap
