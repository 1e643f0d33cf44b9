// opencv_calibration: an OpenCV calibration in cv::FileStorage YAML, read as loadCalibration reads
// a %YAML or .yml file (parseOpenCvYaml on its text), then used as the rig uses it
// (useOpenCvCalibration: its size left to the stream or not, either world frame).
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
  useOpenCvCalibration(p);
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzOpenCvCalibration)
