// opencv_calibration: an OpenCV calibration in cv::FileStorage YAML, read as loadCalibration reads
// a %YAML or .yml file (parseOpenCvYaml on its text), then used as the rig uses it.
#include <cmath>
#include <memory>

#include "config/calibration_file.h"
#include "config/input_error.h"
#include "core/opencv_camera.h"
#include "fuzz/calibration_use.h"
#include "fuzz/fuzz_target.h"

namespace occmap::fuzz {

bool fuzzOpenCvCalibration(Input input) {
  OpenCvParameters p;
  try {
    p = parseOpenCvYaml(asText(input), "/occmap-fuzz/camera.yml");
  } catch (const InputError&) {
    return false;
  }
  require(p.width >= 1 && p.width <= 65536 && p.height >= 1 && p.height <= 65536,
          "an accepted image is 1..65536 pixels a side");
  require(std::isfinite(p.fx) && p.fx > 0 && std::isfinite(p.fy) && p.fy > 0,
          "accepted focal lengths are finite and > 0");
  require(std::isfinite(p.cx) && std::isfinite(p.cy) && p.rvec.allFinite() && p.tvec.allFinite(),
          "accepted parameters are finite");
  for (const double k : p.distortion) require(std::isfinite(k), "accepted distortion is finite");
  useCalibration(std::make_shared<OpenCvCamera>(p), LengthUnit::kMetre);
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzOpenCvCalibration)
