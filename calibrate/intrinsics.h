#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "calibrate/board.h"
#include "core/opencv_camera.h"

namespace occmap {

// What a set of pictures of the board must show before a calibration from them is trusted. A view
// is usable with at least kMinCornersPerView corners and a quarter of the board's, not all on one
// line of the board. The usable views together must
//   - be at least kMinViews;
//   - cover at least kMinCoveredShare of the image with the union of each view's convex hull of
//     corners (the lens is only known where the board was); and
//   - reach every cell of a 3 x 3 grid over the image with some corner: distortion is strongest in
//     the image's corners and along its edges, and a model fitted without them extrapolates there.
inline constexpr int kMinViews = 6;
inline constexpr int kMinCornersPerView = 6;
inline constexpr double kMinCoveredShare = 0.5;

struct ViewReport {
  int corners = 0;      // found in the picture
  bool used = false;    // usable, and used by the calibration
  std::string why_not;  // why it is not used ("no board", "4 corners, fewer than 6")
  double rms_px = 0.0;  // its corners' reprojection error, when used
};

struct IntrinsicsReport {
  std::vector<ViewReport> views;  // one per picture given, in order
  int usable_views = 0;
  double covered_share = 0.0;          // of the image, by the union of the views' hulls
  std::array<bool, 9> cell_reached{};  // the 3 x 3 grid, row by row from the top left
  double rms_px = 0.0;                 // over every corner of every used view
  // One standard deviation of the estimates (OpenCV's, from the residuals), in pixels.
  double fx_sigma_px = 0.0, fy_sigma_px = 0.0, cx_sigma_px = 0.0, cy_sigma_px = 0.0;
  // Empty when calibrated; else why the pictures cannot be trusted and what to do.
  std::string refusal;
};

// The grid cell's name in the refusal ("top left", "centre", ...).
const char* gridCellName(int cell);

struct IntrinsicsResult {
  std::optional<OpenCvParameters> camera;  // rvec and tvec zero: no pose yet
  IntrinsicsReport report;
};

// OpenCV's camera matrix and 5 distortion coefficients (k1 k2 p1 p2 k3) for pictures of
// `image_size`, as occmap holds them (rvec and tvec zero).
OpenCvParameters openCvIntrinsics(const cv::Mat& camera_matrix, const cv::Mat& distortion,
                                  cv::Size image_size);

// Why a lens model cannot be trusted over its whole picture: some pixel on the picture's border has
// no ray, the model's radial term having stopped increasing short of it (a k3 fitted from corners
// that never reached the picture's edge can turn the polynomial down inside it); empty when every
// border pixel has one. Past that radius OpenCV folds points back into the picture.
std::string foldInsidePicture(const OpenCvParameters& camera);

// How far the principal point's uncertainty (one standard deviation, the larger axis) alone may
// turn a pose found with these intrinsics, in degrees: `occmap calibrate pose` takes the principal
// point as given, so σ px off turns the camera by atan(σ / f). Above 0.1 degrees
// (kPrincipalTurnWarningDeg) `occmap calibrate intrinsics` says so: on the simulator's 6 mm
// cameras 15 pictures of a 7 x 5 ChArUco board gave ±1.7 px (0.16 degrees) and left the pose
// 0.12 to 0.13 degrees off, a 9 x 6 chessboard's ±0.8 px (0.08 degrees) 0.05 (docs/calibration.md).
double principalPointTurnDeg(const OpenCvParameters& camera, const IntrinsicsReport& report);
inline constexpr double kPrincipalTurnWarningDeg = 0.1;

// The camera's intrinsics from its pictures of the board (`views`: the corners found in each,
// empty where none were), all of `image_size`, with OpenCV's 5-coefficient model (k1 k2 p1 p2 k3)
// and no skew: cv::calibrateCamera on each view's own corners, so that partly seen ChArUco boards
// count as fully as whole ones. Refused (no camera, report.refusal says why) under the rules above,
// and when the model found folds back inside the picture (foldInsidePicture).
IntrinsicsResult calibrateIntrinsics(const BoardSpec& spec, const std::vector<BoardCorners>& views,
                                     cv::Size image_size);

}  // namespace occmap
