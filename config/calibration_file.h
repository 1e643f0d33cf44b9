#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "core/camera_model.h"
#include "core/opencv_camera.h"
#include "core/tsai_camera.h"

namespace occmap {

// Calibration files as users bring them (ARCHITECTURE.md, Conventions). Every problem with a file's
// content is an InputError naming the file, the line where known and the field.

// Tsai's model in the ETISEO/PETS XML layout:
//   <Camera name="..."><Geometry width height ncx nfx dx dy dpx dpy/>
//   <Intrinsic focal kappa1 cx cy sx/><Extrinsic tx ty tz rx ry rz/></Camera>
// Every attribute is required except dpx (then dx * ncx / nfx, Willson's definition) and dpy (then
// dy); given ones must agree with those definitions. Fields are named "Element.attribute".
TsaiParameters loadTsaiXml(const std::filesystem::path& file);
// The same from text already in memory; `file_name` only names the source in errors.
TsaiParameters parseTsaiXml(std::string_view text, const std::string& file_name);
// The same parameters as that XML, in full precision: what parseTsaiXml reads back exactly.
std::string tsaiXmlText(const TsaiParameters& parameters, const std::string& camera_name);

// OpenCV's pinhole model in the YAML that cv::FileStorage writes (OpenCV's calibration sample):
// image_width, image_height, camera_matrix (3x3, no skew), distortion_coefficients (k1 k2 p1 p2
// [k3]; OpenCV's longer models only when their extra coefficients are zero), rvec, tvec (3 values
// each). Read with yaml-cpp, not cv::FileStorage, whose parser hangs or crashes on some slips
// (docs/fuzzing.md); errors carry the line of the value (a missing key: none).
OpenCvParameters loadOpenCvYaml(const std::filesystem::path& file);
OpenCvParameters parseOpenCvYaml(std::string_view text, const std::string& file_name);
// The same parameters as that YAML (cv::FileStorage's layout), in full precision: what
// parseOpenCvYaml reads back exactly.
std::string openCvYamlText(const OpenCvParameters& parameters);

// A model's calibration file of its own kind (Tsai XML, OpenCV YAML) and the file name extension
// that says so (".xml", ".yaml"); nothing for another kind of model.
struct CalibrationText {
  std::string text;
  std::string extension;
};
std::optional<CalibrationText> calibrationText(const CameraModel& model,
                                               const std::string& camera_name);

// A calibration file of either kind, told apart by content: XML ("<?xml" or "<" first) is Tsai,
// "%YAML" first or a .yml/.yaml name is OpenCV YAML.
struct LoadedCalibration {
  std::shared_ptr<const CameraModel> model;
  LengthUnit units;  // the file's length unit: `units` if given, else mm for Tsai, m for OpenCV
  std::string kind;  // "tsai" or "opencv"
};
LoadedCalibration loadCalibration(const std::filesystem::path& file,
                                  std::optional<LengthUnit> units = std::nullopt);

}  // namespace occmap
