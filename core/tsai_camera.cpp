#include "core/tsai_camera.h"

#include <cmath>
#include <limits>
#include <numbers>

namespace occmap {
namespace {

Pose tsaiPose(const TsaiParameters& p) {
  return Pose{rotationFromTsaiAngles(p.rx, p.ry, p.rz), Eigen::Vector3d(p.tx, p.ty, p.tz)};
}

}  // namespace

void TsaiParameters::setPose(const Pose& pose) {
  const Eigen::Vector3d angles = tsaiAnglesFromRotation(pose.rotation);
  rx = angles.x();
  ry = angles.y();
  rz = angles.z();
  tx = pose.translation.x();
  ty = pose.translation.y();
  tz = pose.translation.z();
}

std::shared_ptr<const CameraModel> TsaiCamera::withPose(const Pose& pose) const {
  TsaiParameters moved = p_;
  moved.setPose(pose);
  return std::make_shared<TsaiCamera>(moved);
}

TsaiCamera::TsaiCamera(const TsaiParameters& parameters)
    : CameraModel(tsaiPose(parameters), parameters.width, parameters.height), p_(parameters) {
  if (p_.kappa1 < 0.0) {
    max_distorted_radius_ = std::sqrt(-1.0 / (3.0 * p_.kappa1));
    max_undistorted_radius_ =
        max_distorted_radius_ * (2.0 / 3.0);  // Rd (1 + kappa1 Rd^2) at the peak
  } else {
    max_distorted_radius_ = std::numeric_limits<double>::infinity();
    max_undistorted_radius_ = std::numeric_limits<double>::infinity();
  }
}

std::optional<double> TsaiCamera::distortedRadius(double ru) const {
  if (ru == 0.0 || p_.kappa1 == 0.0) return ru;
  // Solve Ru = Rd + kappa1 Rd^3, i.e. Rd^3 + c Rd + d = 0 with c = 1/kappa1, d = -c Ru, exactly as
  // Willson's code does (Q, R and D are his names).
  const double c = 1.0 / p_.kappa1;
  const double d = -c * ru;
  const double q = c / 3.0;
  const double r = -d / 2.0;
  const double discriminant = q * q * q + r * r;
  if (discriminant > 0.0) {
    // One real root. For kappa1 > 0 it is the distorted radius; for kappa1 < 0 it is negative: the
    // point lies past the barrel limit, where Willson clamps to the limit. We say "no image".
    const double root = std::sqrt(discriminant);
    const double rd = std::cbrt(r + root) + std::cbrt(r - root);
    if (rd >= 0.0) return rd;
    // Within rounding of the limit the discriminant can come out a hair above zero: that is the
    // limit.
    if (ru <= max_undistorted_radius_) return max_distorted_radius_;
    return std::nullopt;
  }
  if (discriminant == 0.0) {
    // A double root: exactly on the barrel limit (kappa1 < 0), where the positive root is -cbrt(r).
    return -std::cbrt(r);
  }
  // Three real roots (kappa1 < 0 inside the limit): Willson takes the smaller positive one, the
  // only one on the monotonic part of the model.
  const double root = std::sqrt(-discriminant);
  const double s = std::cbrt(std::hypot(r, root));
  const double t = std::atan2(root, r) / 3.0;
  return -s * std::cos(t) + std::numbers::sqrt3 * s * std::sin(t);
}

std::optional<Eigen::Vector2d> TsaiCamera::cameraToPixel(const Eigen::Vector3d& camera) const {
  // Perspective projection onto the sensor plane (undistorted sensor coordinates).
  const double xu = p_.focal * camera.x() / camera.z();
  const double yu = p_.focal * camera.y() / camera.z();
  const double ru = std::hypot(xu, yu);
  if (!(ru <= max_undistorted_radius_)) return std::nullopt;  // also catches NaN
  double xd = xu;
  double yd = yu;
  if (ru != 0.0 && p_.kappa1 != 0.0) {
    const std::optional<double> rd = distortedRadius(ru);
    if (!rd) return std::nullopt;
    const double lambda = *rd / ru;
    xd = xu * lambda;
    yd = yu * lambda;
  }
  // Sensor to frame buffer: Xf = sx Xd / dpx + Cx, Yf = Yd / dpy + Cy.
  return Eigen::Vector2d(p_.sx * xd / p_.dpx + p_.cx, yd / p_.dpy + p_.cy);
}

std::optional<Eigen::Vector3d> TsaiCamera::pixelToCamera(const Eigen::Vector2d& pixel) const {
  // Paper eqs. 5-6: frame buffer to distorted sensor coordinates.
  const double xd = p_.dpx * (pixel.x() - p_.cx) / p_.sx;
  const double yd = p_.dpy * (pixel.y() - p_.cy);
  const double r2 = xd * xd + yd * yd;
  // Past the barrel limit the model folds back: that pixel stands for no ray of the model.
  if (!(r2 <= max_distorted_radius_ * max_distorted_radius_)) return std::nullopt;
  // Paper eqs. 8-10: distorted to undistorted sensor coordinates.
  const double factor = 1.0 + p_.kappa1 * r2;
  return Eigen::Vector3d(xd * factor / p_.focal, yd * factor / p_.focal, 1.0);
}

}  // namespace occmap
