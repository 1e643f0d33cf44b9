#include "config/prepared_rig.h"

#include <utility>

namespace occmap {

PreparedRig prepareRig(const Config& config, const RigOptions& options,
                       std::optional<double> column_height_m,
                       const std::function<void(std::size_t built)>& built) {
  Rig rig = Rig::open(config, options);
  const double height = column_height_m.value_or(config.fusion.column_height_m);
  std::vector<CarveTable> tables = rig.buildTables(height, built);
  return {std::move(rig), std::move(tables), height};
}

}  // namespace occmap
