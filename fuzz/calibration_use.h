#pragma once
// What occmapd does with a calibration once it has loaded: a Camera for the stream, then a carve
// table for each carving mode (Rig::buildTables). A hostile calibration that loads must not crash,
// hang or make a table that points outside the stream (docs/fuzzing.md).

#include <memory>

#include "core/camera_model.h"

namespace occmap::fuzz {

// Throws Finding when a promise of the camera model or the carve table is broken.
void useCalibration(const std::shared_ptr<const CameraModel>& model, LengthUnit units);

}  // namespace occmap::fuzz
