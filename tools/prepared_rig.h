#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/carve_table.h"
#include "daemon/rig.h"

namespace occmap::tools {

// What fuse and coverage both start from: the config's rig opened and its carve tables built (with
// progress on a terminal), its warnings printed under the command's name.
struct PreparedRig {
  Rig rig;
  std::vector<CarveTable> tables;
  double column_height_m;
};

PreparedRig prepareRig(const Config& config, const std::string& command,
                       std::optional<double> column_height_m = std::nullopt);

}  // namespace occmap::tools
