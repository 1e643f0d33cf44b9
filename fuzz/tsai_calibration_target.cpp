// tsai_calibration: a Tsai calibration in the ETISEO/PETS XML layout, read as loadCalibration
// reads a file that starts with '<' (parseTsaiXml on its text), then used as the rig uses it.
#include <cmath>
#include <memory>

#include "config/calibration_file.h"
#include "config/input_error.h"
#include "core/tsai_camera.h"
#include "fuzz/calibration_use.h"
#include "fuzz/fuzz_target.h"

namespace occmap::fuzz {

bool fuzzTsaiCalibration(Input input) {
  TsaiParameters p;
  try {
    p = parseTsaiXml(asText(input), "/occmap-fuzz/camera.xml");
  } catch (const InputError&) {
    return false;
  }
  // calibration_file.h: image sides are whole pixels 1..65536, spacings, focal length and sx > 0,
  // everything finite.
  require(p.width >= 1 && p.width <= 65536 && p.height >= 1 && p.height <= 65536,
          "an accepted image is 1..65536 pixels a side");
  for (const double positive : {p.ncx, p.nfx, p.dx, p.dy, p.dpx, p.dpy, p.focal, p.sx}) {
    require(std::isfinite(positive) && positive > 0,
            "accepted spacings, focal length and sx are finite and > 0");
  }
  for (const double value : {p.kappa1, p.cx, p.cy, p.tx, p.ty, p.tz, p.rx, p.ry, p.rz}) {
    require(std::isfinite(value), "accepted parameters are finite");
  }
  useCalibration(std::make_shared<TsaiCamera>(p), LengthUnit::kMillimetre);
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzTsaiCalibration)
