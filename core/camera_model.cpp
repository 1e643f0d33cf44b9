#include "core/camera_model.h"

#include <cmath>

#include <Eigen/Geometry>

namespace occmap {

double metresPerUnit(LengthUnit unit) {
  switch (unit) {
    case LengthUnit::kMillimetre:
      return 1e-3;
    case LengthUnit::kCentimetre:
      return 1e-2;
    case LengthUnit::kMetre:
      return 1.0;
  }
  return 1.0;
}

std::string_view unitName(LengthUnit unit) {
  switch (unit) {
    case LengthUnit::kMillimetre:
      return "mm";
    case LengthUnit::kCentimetre:
      return "cm";
    case LengthUnit::kMetre:
      return "m";
  }
  return "?";
}

std::optional<LengthUnit> parseLengthUnit(std::string_view text) {
  if (text == "mm") return LengthUnit::kMillimetre;
  if (text == "cm") return LengthUnit::kCentimetre;
  if (text == "m") return LengthUnit::kMetre;
  return std::nullopt;
}

std::optional<ImagePoint> CameraModel::worldToImage(const Eigen::Vector3d& world) const {
  const Eigen::Vector3d camera = pose_.rotation * world + pose_.translation;
  // zc <= 0: behind the camera (or in its focal plane), where the pinhole has no image.
  if (!(camera.z() > 0.0)) return std::nullopt;
  const std::optional<Eigen::Vector2d> pixel = cameraToPixel(camera);
  // A calibration may hold huge finite values (a distortion coefficient of 1e308) whose pixel
  // overflows: that is no image either, never an infinite "pixel" (found by fuzzing).
  if (!pixel || !pixel->allFinite()) return std::nullopt;
  return ImagePoint{*pixel, camera.z()};
}

std::optional<Ray> CameraModel::imageToRay(const Eigen::Vector2d& pixel) const {
  const std::optional<Eigen::Vector3d> camera = pixelToCamera(pixel);
  if (!camera || !camera->allFinite()) return std::nullopt;
  // Paper eq. 13, P_w = R^-1 (P_c - T), applied to the ray's origin (0) and direction.
  return Ray{centre_, to_world_ * *camera};
}

std::optional<PlanePoint> CameraModel::imageToPlane(const Eigen::Vector2d& pixel, double z) const {
  const std::optional<Ray> ray = imageToRay(pixel);
  if (!ray) return std::nullopt;
  const double dz = ray->direction.z();
  if (dz == 0.0) return std::nullopt;  // parallel to the plane: it never meets it
  const double depth = (z - ray->origin.z()) / dz;
  // The plane lies behind the camera along this ray (a pixel above the horizon for the floor).
  if (!(depth > 0.0) || !std::isfinite(depth)) return std::nullopt;
  Eigen::Vector3d world = ray->origin + depth * ray->direction;
  world.z() = z;  // exact, not z plus rounding
  return PlanePoint{world, depth};
}

Eigen::Matrix3d rotationFromTsaiAngles(double rx, double ry, double rz) {
  return (Eigen::AngleAxisd(rz, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(ry, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rx, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Vector3d tsaiAnglesFromRotation(const Eigen::Matrix3d& r) {
  // r31 = -sin(ry), r32 = cos(ry) sin(rx), r33 = cos(ry) cos(rx), r21 = cos(ry) sin(rz), r11 = ...
  return {std::atan2(r(2, 1), r(2, 2)), std::asin(-r(2, 0)), std::atan2(r(1, 0), r(0, 0))};
}

Pose turnedOnItsMount(const Pose& pose, const Eigen::Vector3d& turn) {
  const double angle = turn.norm();
  const Eigen::Matrix3d q = angle > 0 ? Eigen::AngleAxisd(angle, turn / angle).toRotationMatrix()
                                      : Eigen::Matrix3d::Identity();
  return Pose{q * pose.rotation, q * pose.translation};
}

Pose poseLookingAt(const Eigen::Vector3d& position, const Eigen::Vector3d& target) {
  const Eigen::Vector3d forward = (target - position).normalized();
  const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d rotation;
  rotation.row(0) = right;
  rotation.row(1) = down;
  rotation.row(2) = forward;
  return Pose{rotation, -rotation * position};
}

}  // namespace occmap
