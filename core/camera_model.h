#pragma once

#include <memory>
#include <optional>
#include <string_view>

#include <Eigen/Core>

namespace occmap {

// The length unit a calibration file is written in (ARCHITECTURE.md, Conventions: Tsai files are in
// millimetres, an OpenCV file in the units of its tvec).
enum class LengthUnit { kMillimetre, kCentimetre, kMetre };

double metresPerUnit(LengthUnit unit);
std::string_view unitName(LengthUnit unit);
std::optional<LengthUnit> parseLengthUnit(std::string_view text);

// Where a world point lands in the calibration image: `pixel` is (u = column, v = row) with integer
// values at pixel centres; `depth` is the point's z in camera coordinates, in calibration units.
struct ImagePoint {
  Eigen::Vector2d pixel;
  double depth;
};

// A point found on a plane from a pixel, with its depth (camera z) along the pixel's ray.
struct PlanePoint {
  Eigen::Vector3d world;
  double depth;
};

// The world points that image at one pixel: origin + depth * direction, depth > 0. The direction's
// camera-z component is 1, so the parameter along the ray is the point's depth.
struct Ray {
  Eigen::Vector3d origin;
  Eigen::Vector3d direction;
};

// The extrinsic pose shared by every lens model: camera coordinates Xc = rotation * Xw +
// translation.
struct Pose {
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;

  Eigen::Vector3d centre() const { return -rotation.transpose() * translation; }
};

// A calibrated camera in its calibration frame and its file's own units. World to image and image
// to plane; every "no result" is an empty optional, never a number: a point behind the camera or
// beyond the lens model's valid radius has no image, and a pixel beyond that radius has no ray. A
// point that projects outside the image bounds still has a pixel: bounds are the caller's business.
class CameraModel {
 public:
  CameraModel(const Pose& pose, int width, int height)
      : pose_(pose),
        centre_(pose.centre()),
        to_world_(pose.rotation.transpose()),
        width_(width),
        height_(height) {}
  virtual ~CameraModel() = default;
  CameraModel(const CameraModel&) = default;
  CameraModel& operator=(const CameraModel&) = default;

  // Calibration frame size in pixels.
  int width() const { return width_; }
  int height() const { return height_; }
  const Pose& pose() const { return pose_; }
  // The camera's centre in the calibration frame (pose().centre(), computed once).
  const Eigen::Vector3d& centre() const { return centre_; }

  std::optional<ImagePoint> worldToImage(const Eigen::Vector3d& world) const;
  std::optional<Ray> imageToRay(const Eigen::Vector2d& pixel) const;
  // Closed form: the pixel's ray meets the horizontal plane at height z in front of the camera, or
  // there is no result (a ray parallel to the plane or one that reaches it only behind the camera).
  std::optional<PlanePoint> imageToPlane(const Eigen::Vector2d& pixel, double z) const;
  // The same lens at another pose (a camera knocked and re-posed, core/view_motion.h).
  virtual std::shared_ptr<const CameraModel> withPose(const Pose& pose) const = 0;

 protected:
  // Lens model from camera coordinates (zc > 0 guaranteed) to a pixel; empty beyond the valid
  // radius.
  virtual std::optional<Eigen::Vector2d> cameraToPixel(const Eigen::Vector3d& camera) const = 0;
  // Lens model from a pixel to the direction (x, y, 1) in camera coordinates; empty beyond the
  // valid radius (where the model folds back and one pixel would stand for two rays).
  virtual std::optional<Eigen::Vector3d> pixelToCamera(const Eigen::Vector2d& pixel) const = 0;

 private:
  Pose pose_;
  // The pose turned round once, not for every pixel's ray: a carve table asks for some hundred
  // thousand rays, and instrumented (a sanitizer's build) each -R^T t and R^T x was a call of its
  // own, an eighth of pipeline_test's time under ASan. The same products, so the same rays to the
  // bit (R^T held row-major is R^T as Eigen reads it through transpose(), and multiplied in the
  // same order).
  Eigen::Vector3d centre_;
  Eigen::Matrix<double, 3, 3, Eigen::RowMajor> to_world_;
  int width_;
  int height_;
};

// R = Rz(rz) * Ry(ry) * Rx(rx), Willson's convention for Tsai's model (and ETISEO's files).
Eigen::Matrix3d rotationFromTsaiAngles(double rx, double ry, double rz);
// The angles (rx, ry, rz) of a rotation in that convention (|ry| < pi/2 taken).
Eigen::Vector3d tsaiAnglesFromRotation(const Eigen::Matrix3d& rotation);

// The pose of a camera turned on its mount by `turn` (axis times angle in radians, in camera
// coordinates: x right, y down, z along the optical axis): Xc' = Q Xc = Q (R Xw + T), the same
// centre (a knocked camera, core/repose.h).
Pose turnedOnItsMount(const Pose& pose, const Eigen::Vector3d& turn);

// The pose of a camera at `position` looking at `target` with the image's rows horizontal (image +x
// to the right, +y down, world z up), for simulated scenes and tests.
Pose poseLookingAt(const Eigen::Vector3d& position, const Eigen::Vector3d& target);

}  // namespace occmap
