#pragma once
// Whether a camera whose view no change of light explains has been moved (knocked, turned on its
// mount) and by how much (issue 13, docs/lighting.md). A moved camera is the one case where the
// light's model must not simply learn the new view: its calibration still describes the old pose,
// so its clear rays would free cells it no longer looks at. Telling it apart from a covered lens,
// lights out or a crowd lets the status say what to do ("moved 12 px: put it back or recalibrate").
//
// The motion is measured as the background's image moved over the live one: zero-mean normalised
// cross-correlation (ZNCC, blind to the light's gain and offset) searched over shifts on an image
// pyramid, coarse to fine, then refined in a 3 x 3 grid of regions; the regions' shifts give an
// image translation and a turn about the image centre by least squares. A camera turned by a small
// angle about any axis moves its image so, to within a pixel or two at the borders.
// No I/O, no threads; after construction nothing is allocated.

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/camera.h"
#include "core/image.h"

namespace occmap {

struct ViewMotion {
  // The live view is the background's, moved: the moved background matches it well, leaves at
  // most kMostMismatchLeft of what the unmoved one leaves unmatched (1 - ZNCC), and the motion
  // reaches at least a pixel somewhere in the image.
  bool moved = false;
  // Where the background's content lies in the live view, less where it lay (stream pixels, at the
  // image centre; +x right, +y down).
  double shift_x_px = 0;
  double shift_y_px = 0;
  // The turn about the image centre, degrees, positive from +x towards +y (clockwise as seen).
  double turn_deg = 0;
  // ZNCC of the background's detail with the live view's (-1 to 1), over the regions followed,
  // moved as found and not moved (negative values counted as 0).
  double match = 0;
  double match_unmoved = 0;
  // How far the regions' own shifts lie from the fitted motion (RMS, pixels): small for a camera
  // turned on its mount, large when the view changed in another way as well.
  double residual_px = 0;
  // The regions with texture enough to follow (`regions` of the 5 x 5): where each lies in the
  // background (its centre, stream pixels) and how far its content moved.
  struct Region {
    Eigen::Vector2d at = Eigen::Vector2d::Zero();
    Eigen::Vector2d shift = Eigen::Vector2d::Zero();
  };
  std::array<Region, 25> region{};
  int regions = 0;
  // The largest displacement of the image the motion makes over its four corners (pixels).
  double largestDisplacementPx(int width, int height) const;
  // The shift that the translation and turn give at stream pixel `at`.
  Eigen::Vector2d predictedShift(const Eigen::Vector2d& at, int width, int height) const;
};

class ViewMotionEstimator {
 public:
  // `background` is copied (into its pyramid). Images smaller than 32 x 24 are never "moved".
  explicit ViewMotionEstimator(ImageView background);

  // The motion of `live` (the background's size) against the background. Some 7 ms for 640 x 480
  // (bench/view_motion_bench): meant for a degraded camera's frame now and then, not every frame.
  ViewMotion estimate(ImageView live);

  // Thresholds of `moved`.
  static constexpr double kMinMatch = 0.5;
  // A share, not a difference: on real, finely textured views a half-degree turn about the
  // optical axis leaves the unmoved match at 0.86 and the moved one at 0.95 (EPFL Terrace's c2).
  static constexpr double kMostMismatchLeft = 0.6;
  static constexpr double kMinDisplacementPx = 1.0;

 private:
  struct Window {
    int x0, y0, x1, y1;  // background pixels, half-open
  };
  static Eigen::Vector2d textureCentre(const Image& background, Window window, int dx, int dy);
  static void fitImageMotion(ViewMotion& motion, int width, int height);
  static double zncc(const Image& background, const Image& live, Window window, int dx, int dy);
  // The best integer shift within `radius` of (cx, cy) on one level; its ZNCC in `best_match`.
  static void search(const Image& background, const Image& live, Window window, int cx, int cy,
                     int radius, int& best_x, int& best_y, double& best_match);

  // Pyramids, level 0 the full image: the background's detail, the live view's detail and its
  // raw levels (level 0 unused: the live view itself).
  std::vector<Image> background_;
  std::vector<Image> live_;
  std::vector<Image> live_raw_;
  std::vector<std::uint32_t> column_sums_;  // keepDetail's scratch
  std::vector<std::uint8_t> fine_;
  std::vector<std::uint8_t> coarse_;
};

// How the camera turned on its mount, from the regions' motion and its lens model (which the
// image's translation and turn only approximate: a turn moves the image's borders more than its
// centre): the rotation Q of its camera coordinates (new = Q old, about its centre) that best
// takes each region's ray before to its ray after (Kabsch's method), as axis times angle in
// radians (x right, y down, z along the optical axis).
struct CameraTurn {
  bool found = false;  // at least three regions, each with a ray
  Eigen::Vector3d turn = Eigen::Vector3d::Zero();
  double degrees() const;
  // How far the regions' motion lies from what the turn predicts (RMS, stream pixels): a camera
  // only turned leaves a fraction of a pixel; one moved along as well, or a view otherwise
  // changed, leaves more.
  double residual_px = 0;
};
CameraTurn cameraTurn(const Camera& camera, const ViewMotion& motion);

}  // namespace occmap
