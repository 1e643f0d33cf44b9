#pragma once
// A rig of one camera a test made itself: 100x100 pixels, 2 m above the floor looking straight
// down (tsai_xml.h), background grey 120, threshold 25, over a 30 x 30 map of 4 cm cells. For
// tests that put a FrameSource of their own (bad frames, failures) into the live pipeline.
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "config/calibration_file.h"
#include "config/config.h"
#include "config/prepared_rig.h"
#include "tsai_xml.h"

namespace occmap::testing {

inline PreparedRig downwardRig(const std::string& name, std::unique_ptr<FrameSource> source,
                               double column_height_m) {
  const std::string height = column_height_m > 0 ? "0.3" : "0";
  Config config = parseConfig(
      "map: {origin_m: [-0.6, -0.6], cell_size_m: 0.04, width: 30, height: 30}\n"
      "fusion: {threshold: 25, column_height_m: " +
          height +
          "}\n"
          "transport: {lcm_url: \"memq://\"}\n"
          "cameras:\n  - {name: " +
          name + ", source: \"sim://room/c0\", fps: 100}\n",
      name + ".yaml");
  RigCamera camera;
  camera.name = name;
  camera.camera =
      std::make_unique<Camera>(std::make_shared<TsaiCamera>(parseTsaiXml(kDownwardXml, "down.xml")),
                               LengthUnit::kMillimetre, 100, 100);
  camera.background = Image(100, 100, 120);
  camera.threshold = 25;
  camera.source = std::move(source);
  std::vector<RigCamera> cameras;
  cameras.push_back(std::move(camera));
  Rig rig = Rig::assemble(config, std::move(cameras));
  std::vector<CarveTable> tables = rig.buildTables(config.fusion.column_height_m);
  return {std::move(rig), std::move(tables), config.fusion.column_height_m};
}

}  // namespace occmap::testing
