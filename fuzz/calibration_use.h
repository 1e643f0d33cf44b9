#pragma once
// What occmapd does with a calibration once it has loaded: a Camera for the stream, then a carve
// table for each carving mode (Rig::buildTables). A hostile calibration that loads must not crash,
// hang or make a table that points outside the stream (docs/fuzzing.md).

#include <memory>

#include "core/camera_model.h"
#include "core/opencv_camera.h"

namespace occmap::fuzz {

// Throws Finding when a promise of the camera model or the carve table is broken.
void useCalibration(const std::shared_ptr<const CameraModel>& model, LengthUnit units);

// An OpenCV calibration a loader accepted (YAML or XML): its parameters as the loader promises,
// then used as the rig uses it: with a 640 x 480 stream's size when the file leaves its size out
// (LoadedCalibration::modelFor), in OpenCV's right-handed world frame and in a left-handed one
// (world_frame: left-handed).
void useOpenCvCalibration(OpenCvParameters p);

}  // namespace occmap::fuzz
