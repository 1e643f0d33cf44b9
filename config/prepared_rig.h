#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <vector>

#include "config/config.h"
#include "config/rig.h"
#include "core/carve_table.h"

namespace occmap {

// What every program starts from (occmapd, occmap fuse and coverage, the benchmarks): the
// config's rig opened and one carve table per camera built for its map. Building the tables can
// take seconds (column tables of large maps); occmapd builds a reload's while the old config runs.
struct PreparedRig {
  Rig rig;
  std::vector<CarveTable> tables;  // one per camera, in the rig's order
  double column_height_m = 0;      // what the tables were built for
};

// Opens the rig (InputError as Rig::open) and builds its tables at `column_height_m`, the config's
// own by default. `built` hears after each camera's table (progress). The rig's warnings are the
// caller's to report (a log line, or stderr under a command's name).
PreparedRig prepareRig(const Config& config, const RigOptions& options = {},
                       std::optional<double> column_height_m = std::nullopt,
                       const std::function<void(std::size_t built)>& built = {});

}  // namespace occmap
