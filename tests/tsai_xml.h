#pragma once
// Tsai calibrations as ETISEO/PETS XML files, for tests that give a live camera (which has no scene
// to take a calibration from) the geometry of one of the simulator's cameras.

#include <cstdio>
#include <string>

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
  char text[1024];
  std::snprintf(text, sizeof text,
                "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
                "<Camera name=\"%s\">\n"
                "  <Geometry width=\"%d\" height=\"%d\" ncx=\"%.17g\" nfx=\"%.17g\" dx=\"%.17g\" "
                "dy=\"%.17g\" dpx=\"%.17g\" dpy=\"%.17g\"/>\n"
                "  <Intrinsic focal=\"%.17g\" kappa1=\"%.17g\" cx=\"%.17g\" cy=\"%.17g\" "
                "sx=\"%.17g\"/>\n"
                "  <Extrinsic tx=\"%.17g\" ty=\"%.17g\" tz=\"%.17g\" rx=\"%.17g\" ry=\"%.17g\" "
                "rz=\"%.17g\"/>\n"
                "</Camera>\n",
                name.c_str(), p.width, p.height, p.ncx, p.nfx, p.dx, p.dy, p.dpx, p.dpy, p.focal,
                p.kappa1, p.cx, p.cy, p.sx, p.tx, p.ty, p.tz, p.rx, p.ry, p.rz);
  return text;
}

}  // namespace occmap::testing
