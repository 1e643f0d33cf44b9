// opencv_xml_calibration: an OpenCV calibration in cv::FileStorage XML (WILDTRACK's, MultiviewX's
// files), read as loadCalibration reads an <opencv_storage> file (parseOpenCvStorage on its text:
// libxml2, then the checks of config/opencv_calibration.cpp), then used as the rig uses it: with
// the stream's size when the file leaves its size out, in OpenCV's right-handed world frame and in
// a left-handed one (world_frame: left-handed).
#include "config/calibration_file.h"
#include "config/input_error.h"
#include "core/opencv_camera.h"
#include "fuzz/calibration_use.h"
#include "fuzz/fuzz_target.h"

namespace occmap::fuzz {

bool fuzzOpenCvXmlCalibration(Input input) {
  OpenCvParameters p;
  try {
    p = parseOpenCvStorage(asText(input), "/occmap-fuzz/camera.xml");
  } catch (const InputError&) {
    return false;
  }
  useOpenCvCalibration(p);
  return true;
}

}  // namespace occmap::fuzz

OCCMAP_FUZZ_ENTRY(occmap::fuzz::fuzzOpenCvXmlCalibration)
