#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "core/camera_model.h"

namespace occmap {

// The world frame a calibration's rvec and tvec were made in. OpenCV's own is right-handed.
// MultiviewX's (made with Unity) is left-handed: R(rvec) Xw + tvec then puts every floor point
// behind the camera, yet cv::projectPoints, which divides by the depth whatever its sign, lands it
// in the right pixel. That projection is the camera's with its frame mirrored, Xc = -(R Xw + t): an
// improper rotation (determinant -1), which is how such a camera is modelled here.
enum class WorldFrame : std::uint8_t { kRightHanded, kLeftHanded };

// OpenCV's pinhole model as cv::calibrateCamera and cv::projectPoints define it, with the pose
// Xc = R(rvec) Xw + tvec and the distortion coefficients in OpenCV's order: k1 k2 p1 p2 k3, then
// the rational model's k4 k5 k6 (CALIB_RATIONAL_MODEL) and the thin prism's s1 s2 s3 s4
// (CALIB_THIN_PRISM_MODEL). The usual 5-coefficient model has the last seven zero.
struct OpenCvParameters {
  static constexpr std::size_t kDistortionCount = 12;
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, kDistortionCount> distortion{};  // k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 s4
  Eigen::Vector3d rvec = Eigen::Vector3d::Zero();
  Eigen::Vector3d tvec = Eigen::Vector3d::Zero();
  WorldFrame world_frame = WorldFrame::kRightHanded;  // what rvec and tvec are written in
};

class OpenCvCamera final : public CameraModel {
 public:
  explicit OpenCvCamera(const OpenCvParameters& parameters);

  const OpenCvParameters& parameters() const { return p_; }

  // The normalised radius r = |(x, y)| / z where the radial term r (1 + k1 r^2 + k2 r^4 + k3 r^6) /
  // (1 + k4 r^2 + k5 r^4 + k6 r^6) stops increasing or its denominator reaches zero (infinite if
  // neither happens). Past it OpenCV folds points back into the picture; we give them no image, and
  // no pixel maps past it.
  double maxRadius() const { return max_radius_; }

  std::shared_ptr<const CameraModel> withPose(const Pose& pose) const override;

 protected:
  std::optional<Eigen::Vector2d> cameraToPixel(const Eigen::Vector3d& camera) const override;
  std::optional<Eigen::Vector3d> pixelToCamera(const Eigen::Vector2d& pixel) const override;

 private:
  Eigen::Vector2d distort(const Eigen::Vector2d& normalised) const;

  OpenCvParameters p_;
  double max_radius_;
};

// Rodrigues' formula: the rotation matrix of a rotation vector (axis times angle), as
// cv::Rodrigues.
Eigen::Matrix3d rotationFromRodrigues(const Eigen::Vector3d& rvec);
// The rotation vector of a rotation matrix, as cv::Rodrigues the other way.
Eigen::Vector3d rodriguesFromRotation(const Eigen::Matrix3d& rotation);

}  // namespace occmap
