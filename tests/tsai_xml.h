#pragma once
// Tsai calibrations as ETISEO/PETS XML files, for tests that give a live camera (which has no scene
// to take a calibration from) the geometry of one of the simulator's cameras.

#include <string>

#include "config/calibration_file.h"
#include "core/tsai_camera.h"

namespace occmap::testing {

// A 100x100 camera 2000 mm above (0, 0) looking straight down: one pixel is 10 mm on the floor.
// Line 4 is <Intrinsic> (tests that break a value there expect that line in the error).
inline constexpr const char* kDownwardXml = R"(<?xml version="1.0" encoding="UTF-8"?>
<Camera name="down">
  <Geometry width="100" height="100" ncx="100" nfx="100" dx="0.01" dy="0.01" dpx="0.01" dpy="0.01"/>
  <Intrinsic focal="2.0" kappa1="0" cx="49.5" cy="49.5" sx="1"/>
  <Extrinsic tx="0" ty="0" tz="2000" rx="3.141592653589793" ry="0" rz="0"/>
</Camera>
)";

inline std::string tsaiXml(const TsaiParameters& p, const std::string& name = "camera") {
  return tsaiXmlText(p, name);
}

}  // namespace occmap::testing
