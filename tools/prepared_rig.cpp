#include "tools/prepared_rig.h"

#include <cstdio>

#include "tools/progress.h"

namespace occmap::tools {

PreparedRig prepareRig(const Config& config, const std::string& command,
                       std::optional<double> column_height_m) {
  Rig rig = Rig::open(config);
  const double height = column_height_m.value_or(config.fusion.column_height_m);
  std::vector<CarveTable> tables;
  {
    Progress progress("carve tables", rig.cameras().size());
    tables = rig.buildTables(height, [&](std::size_t built) { progress.update(built); });
  }
  for (const std::string& warning : rig.warnings()) {
    std::fprintf(stderr, "occmap %s: warning: %s\n", command.c_str(), warning.c_str());
  }
  return {std::move(rig), std::move(tables), height};
}

}  // namespace occmap::tools
