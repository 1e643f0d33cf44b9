#include "core/opencv_camera.h"

#include <cmath>
#include <limits>

#include <Eigen/Geometry>

namespace occmap {
namespace {

// The radial factor N(s) / D(s) of OpenCV's rational model at s = r^2, N = 1 + k1 s + k2 s^2 + k3
// s^3 and D = 1 + k4 s + k5 s^2 + k6 s^3 (D = 1 in the 5-coefficient model), with its derivative in
// s.
struct Radial {
  double numerator, denominator, factor, slope_in_s;
};

Radial radialAt(const OpenCvParameters& p, double s) {
  const auto& k = p.distortion;
  const double n = 1.0 + s * (k[0] + s * (k[1] + s * k[4]));
  const double dn = k[0] + s * (2.0 * k[1] + s * 3.0 * k[4]);
  const double d = 1.0 + s * (k[5] + s * (k[6] + s * k[7]));
  const double dd = k[5] + s * (2.0 * k[6] + s * 3.0 * k[7]);
  return {n, d, n / d, (dn * d - n * dd) / (d * d)};
}

// Smallest positive s = r^2 past which r N(s) / D(s) no longer increases or D has reached zero (a
// pole), or infinity. The derivative in r has the sign of N D + 2 s (N' D - N D'): in the
// 5-coefficient model 1 + 3 k1 s + 5 k2 s^2 + 7 k3 s^3. A change of sign is bracketed on a
// geometric grid and then bisected to the last bit; a root where the derivative only touches zero
// leaves the term increasing, so skipping it is right.
double smallestRadiusSquaredPastWhichItFolds(const OpenCvParameters& p) {
  auto increasing = [&](double s) {
    const Radial r = radialAt(p, s);
    const double slope =
        r.numerator * r.denominator + 2.0 * s * r.slope_in_s * r.denominator * r.denominator;
    return r.denominator > 0.0 && slope > 0.0;
  };
  double low = 0.0;
  // The normalised radius of any real lens is far below 1e4 (an angle of 89.99 degrees).
  for (double high = 1e-8; high <= 1e8; high *= 1.05) {
    if (!increasing(high)) {
      for (int i = 0; i < 200 && low < high; ++i) {
        const double mid = 0.5 * (low + high);
        if (mid <= low || mid >= high) break;
        (increasing(mid) ? low : high) = mid;
      }
      return low;
    }
    low = high;
  }
  return std::numeric_limits<double>::infinity();
}

}  // namespace

Eigen::Matrix3d rotationFromRodrigues(const Eigen::Vector3d& rvec) {
  const double angle = rvec.norm();
  if (angle == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, rvec / angle).toRotationMatrix();
}

Eigen::Vector3d rodriguesFromRotation(const Eigen::Matrix3d& rotation) {
  const Eigen::AngleAxisd angle_axis(rotation);
  return angle_axis.axis() * angle_axis.angle();
}

namespace {

// +1 for a right-handed world, -1 for a left-handed one: the camera frame mirrored (WorldFrame).
double handedness(const OpenCvParameters& p) {
  return p.world_frame == WorldFrame::kLeftHanded ? -1.0 : 1.0;
}

}  // namespace

std::shared_ptr<const CameraModel> OpenCvCamera::withPose(const Pose& pose) const {
  // The file's rvec and tvec of the new pose, in the file's own world frame.
  OpenCvParameters moved = p_;
  const double sign = handedness(p_);
  moved.rvec = rodriguesFromRotation(sign * pose.rotation);
  moved.tvec = sign * pose.translation;
  return std::make_shared<OpenCvCamera>(moved);
}

OpenCvCamera::OpenCvCamera(const OpenCvParameters& parameters)
    : CameraModel(Pose{handedness(parameters) * rotationFromRodrigues(parameters.rvec),
                       handedness(parameters) * parameters.tvec},
                  parameters.width, parameters.height),
      p_(parameters) {
  max_radius_ = std::sqrt(smallestRadiusSquaredPastWhichItFolds(p_));
}

Eigen::Vector2d OpenCvCamera::distort(const Eigen::Vector2d& n) const {
  const auto& k = p_.distortion;
  const double p1 = k[2], p2 = k[3];
  const double x = n.x();
  const double y = n.y();
  const double r2 = x * x + y * y;
  const double radial = radialAt(p_, r2).factor;
  return {x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + r2 * (k[8] + r2 * k[9]),
          y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + r2 * (k[10] + r2 * k[11])};
}

std::optional<Eigen::Vector2d> OpenCvCamera::cameraToPixel(const Eigen::Vector3d& camera) const {
  const Eigen::Vector2d normalised(camera.x() / camera.z(), camera.y() / camera.z());
  if (!(normalised.norm() <= max_radius_)) return std::nullopt;
  const Eigen::Vector2d d = distort(normalised);
  return Eigen::Vector2d(p_.fx * d.x() + p_.cx, p_.fy * d.y() + p_.cy);
}

std::optional<Eigen::Vector3d> OpenCvCamera::pixelToCamera(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d target((pixel.x() - p_.cx) / p_.fx, (pixel.y() - p_.cy) / p_.fy);
  // Newton's method on distort(n) = target from n = target. Inside the monotonic radius the map is
  // one-to-one and this converges in a few steps; a pixel that no point inside it reaches has no
  // ray.
  Eigen::Vector2d n = target;
  const auto& k = p_.distortion;
  const double p1 = k[2], p2 = k[3];
  for (int iteration = 0; iteration < 50; ++iteration) {
    const Eigen::Vector2d residual = distort(n) - target;
    if (residual.norm() <= 1e-15 * (1.0 + target.norm())) break;
    const double x = n.x();
    const double y = n.y();
    const double r2 = x * x + y * y;
    const Radial radial = radialAt(p_, r2);
    const double dradial = radial.slope_in_s;  // d radial / d r2
    // The thin prism's s1 r^2 + s2 r^4 (in x) and s3 r^2 + s4 r^4 (in y), differentiated in r2.
    const double prism_x = k[8] + 2.0 * r2 * k[9];
    const double prism_y = k[10] + 2.0 * r2 * k[11];
    Eigen::Matrix2d jacobian;
    jacobian(0, 0) =
        radial.factor + 2.0 * x * x * dradial + 2.0 * p1 * y + 6.0 * p2 * x + 2.0 * x * prism_x;
    jacobian(0, 1) = 2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y + 2.0 * y * prism_x;
    jacobian(1, 0) = 2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y + 2.0 * x * prism_y;
    jacobian(1, 1) =
        radial.factor + 2.0 * y * y * dradial + 6.0 * p1 * y + 2.0 * p2 * x + 2.0 * y * prism_y;
    Eigen::Vector2d step = jacobian.partialPivLu().solve(residual);
    if (!step.allFinite()) return std::nullopt;
    n -= step;
    // Keep the iterate on the model's valid part so it cannot converge to a folded-back root.
    const double radius = n.norm();
    if (radius > max_radius_) n *= max_radius_ / radius;
  }
  if (!(n.norm() <= max_radius_)) return std::nullopt;
  if (!((distort(n) - target).norm() <= 1e-9 * (1.0 + target.norm()))) return std::nullopt;
  return Eigen::Vector3d(n.x(), n.y(), 1.0);
}

}  // namespace occmap
