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

// OpenCV's pinhole model as cv::FileStorage writes it (OpenCV's calibration sample), in YAML or
// XML: image_width, image_height (both or neither: without them the size is the stream's, as in
// WILDTRACK's and MultiviewX's files; width and height are then 0 here), camera_matrix (3x3, no
// skew), distortion_coefficients (k1 k2 p1 p2 [k3]; OpenCV's longer models only when their extra
// coefficients are zero), rvec, tvec (3 values each). Read with yaml-cpp and libxml2, not
// cv::FileStorage (config/storage_node.h says why); errors carry the line of the value (a missing
// key: none).
OpenCvParameters loadOpenCvYaml(const std::filesystem::path& file);
OpenCvParameters parseOpenCvYaml(std::string_view text, const std::string& file_name);
// The same in YAML or XML, told apart by content ('<' first is XML).
OpenCvParameters parseOpenCvStorage(std::string_view text, const std::string& file_name);
// Intrinsics (camera_matrix, distortion_coefficients, the image size if known) in one file and
// extrinsics (rvec, tvec) in another, each YAML or XML, as WILDTRACK and MultiviewX ship them.
OpenCvParameters loadOpenCvCalibration(const std::filesystem::path& intrinsics,
                                       const std::filesystem::path& extrinsics);
// A camera's intrinsics alone (camera_matrix, distortion_coefficients, the image size if known),
// from a file that may or may not hold a pose too; rvec and tvec are left zero.
OpenCvParameters loadOpenCvIntrinsics(const std::filesystem::path& file);
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

// Where a camera's calibration is: one file, or an OpenCV camera's intrinsics and extrinsics in
// two.
struct CalibrationFiles {
  std::filesystem::path file;                       // the whole calibration, or its intrinsics
  std::optional<std::filesystem::path> extrinsics;  // rvec and tvec in a file of their own
};

// A calibration file of either kind, told apart by content: XML with <opencv_storage> is OpenCV's,
// other XML ("<?xml" or "<" first) is Tsai's, "%YAML" first or a .yml/.yaml name is OpenCV YAML.
// With extrinsics in a file of their own the calibration is OpenCV's. A left-handed world frame
// (Unity's, MultiviewX's) is only known to OpenCV calibrations: asked of a Tsai file, an
// InputError.
struct LoadedCalibration {
  std::shared_ptr<const CameraModel> model;
  LengthUnit units;  // the file's length unit: `units` if given, else mm for Tsai, m for OpenCV
  std::string kind;  // "tsai" or "opencv"

  // Whether the file leaves the image size out, so that it is the stream's.
  bool sizeFromStream() const { return model->width() == 0; }
  // The model for a stream of this size: the file's own if it gives its size, else the same camera
  // with the stream's size.
  std::shared_ptr<const CameraModel> modelFor(int stream_width, int stream_height) const;
};
LoadedCalibration loadCalibration(const CalibrationFiles& files,
                                  std::optional<LengthUnit> units = std::nullopt,
                                  WorldFrame world_frame = WorldFrame::kRightHanded);
LoadedCalibration loadCalibration(const std::filesystem::path& file,
                                  std::optional<LengthUnit> units = std::nullopt);

}  // namespace occmap
