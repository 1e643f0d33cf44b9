#pragma once

#include "core/camera_model.h"

namespace occmap {

// Tsai's camera model with its parameters as Willson's reference implementation (and the
// ETISEO/PETS XML files) name them. Lengths in millimetres (or the file's own unit), angles in
// radians.
struct TsaiParameters {
  int width = 0;  // image size in pixels
  int height = 0;
  double ncx = 0;  // sensor elements in x
  double nfx = 0;  // pixels in a frame grabber row
  double dx = 0;   // sensor element spacing
  double dy = 0;
  double dpx = 0;  // effective pixel spacing, dx * ncx / nfx
  double dpy = 0;
  double focal = 0;   // f
  double kappa1 = 0;  // radial distortion on the sensor plane: Xu = Xd (1 + kappa1 r^2)
  double cx = 0;      // image centre in pixels
  double cy = 0;
  double sx = 1;                  // horizontal scale factor
  double tx = 0, ty = 0, tz = 0;  // T: Xc = R Xw + T
  double rx = 0, ry = 0, rz = 0;  // R = Rz(rz) Ry(ry) Rx(rx)

  // Sets R (as its three angles) and T from a pose, e.g. poseLookingAt().
  void setPose(const Pose& pose);
};

class TsaiCamera final : public CameraModel {
 public:
  explicit TsaiCamera(const TsaiParameters& parameters);

  const TsaiParameters& parameters() const { return p_; }

  // For kappa1 < 0 (pincushion on the sensor plane) the undistorted radius Ru = Rd (1 + kappa1
  // Rd^2) peaks at Rd = sqrt(-1 / (3 kappa1)); past it the model folds back. These are that limit
  // on the distorted (sensor) and undistorted radius, infinite for kappa1 >= 0.
  double maxDistortedRadius() const { return max_distorted_radius_; }
  double maxUndistortedRadius() const { return max_undistorted_radius_; }

  // Willson's undistorted_to_distorted_sensor_coord: the distorted radius for an undistorted one by
  // Cardan's formula, or nothing past the barrel limit (where Willson clamps and warns).
  std::optional<double> distortedRadius(double undistorted_radius) const;

  std::shared_ptr<const CameraModel> withPose(const Pose& pose) const override;

 protected:
  std::optional<Eigen::Vector2d> cameraToPixel(const Eigen::Vector3d& camera) const override;
  std::optional<Eigen::Vector3d> pixelToCamera(const Eigen::Vector2d& pixel) const override;

 private:
  TsaiParameters p_;
  double max_distorted_radius_;
  double max_undistorted_radius_;
};

}  // namespace occmap
