#pragma once
// Configs for tests of the live daemon.

#include <string>

namespace occmap::testing {

// A small simulated rig for daemon tests: the paper's room, four cameras, a 256 x 256 map of 4 cm
// cells (fast to build), LCM in process memory unless told otherwise.
inline std::string simRoomConfig(const std::string& lcm_url = "memq://",
                                 const std::string& extra_fusion = "",
                                 const std::string& column_height_m = "0") {
  return "map: {origin_m: [-0.62, -1.87], cell_size_m: 0.04, width: 256, height: 256}\n"
         "fusion: {threshold: 20, column_height_m: " +
         column_height_m + extra_fusion +
         "}\n"
         "transport: {lcm_url: \"" +
         lcm_url +
         "\"}\n"
         "cameras:\n"
         "  - {name: c0, source: \"sim://room/c0\"}\n"
         "  - {name: c1, source: \"sim://room/c1\"}\n"
         "  - {name: c2, source: \"sim://room/c2\"}\n"
         "  - {name: c3, source: \"sim://room/c3\"}\n";
}

// The example's map (examples/sim-room.yaml: 512 x 512 cells of 2 cm) as the daemon tests' map
// above, 256 x 256 cells of 4 cm over the same floor: a quarter of the cells, whose tables, fusion
// and ground truth are most of what an `occmap fuse` of the room costs under the sanitizers. ""
// when the config does not have the example's map.
inline std::string inCoarseMap(std::string config) {
  const std::string fine = "  cell_size_m: 0.02\n  width: 512\n  height: 512\n";
  const std::size_t at = config.find(fine);
  if (at == std::string::npos) return "";
  config.replace(at, fine.size(), "  cell_size_m: 0.04\n  width: 256\n  height: 256\n");
  return config;
}

// A config's simulated cameras moved to another built-in scene of the same room (sim://room/cK ->
// sim://<scene>/cK), such as "room-light".
inline std::string inScene(std::string config, const std::string& scene) {
  const std::string room = "sim://room/";
  for (std::size_t at = 0; (at = config.find(room, at)) != std::string::npos;) {
    config.replace(at, room.size(), "sim://" + scene + "/");
    at += scene.size() + 7;
  }
  return config;
}

}  // namespace occmap::testing
