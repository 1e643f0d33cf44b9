#include "core/camera.h"

#include <cmath>
#include <utility>

#include <Eigen/Geometry>

namespace occmap {

Camera::Camera(std::shared_ptr<const CameraModel> model, LengthUnit units, int stream_width,
               int stream_height, ImageRegion region)
    : model_(std::move(model)),
      metres_per_unit_(occmap::metresPerUnit(units)),
      stream_width_(stream_width),
      stream_height_(stream_height),
      region_(region) {
  if (region_.width <= 0 || region_.height <= 0) {
    region_ = ImageRegion{0, 0, static_cast<double>(model_->width()),
                          static_cast<double>(model_->height())};
  }
  scale_x_ = stream_width_ / region_.width;
  scale_y_ = stream_height_ / region_.height;
}

Eigen::Vector2d Camera::calibrationToStream(const Eigen::Vector2d& c) const {
  return {(c.x() - region_.x0 + 0.5) * scale_x_ - 0.5, (c.y() - region_.y0 + 0.5) * scale_y_ - 0.5};
}

Eigen::Vector2d Camera::streamToCalibration(const Eigen::Vector2d& s) const {
  return {(s.x() + 0.5) / scale_x_ - 0.5 + region_.x0, (s.y() + 0.5) / scale_y_ - 0.5 + region_.y0};
}

std::optional<Eigen::Vector2d> Camera::worldToStream(const Eigen::Vector3d& world_m) const {
  const std::optional<ImagePoint> image = model_->worldToImage(world_m / metres_per_unit_);
  if (!image) return std::nullopt;
  // Scaled to the stream, a pixel near the largest double can still overflow: no pixel then.
  const Eigen::Vector2d stream = calibrationToStream(image->pixel);
  if (!stream.allFinite()) return std::nullopt;
  return stream;
}

std::optional<Ray> Camera::streamToRay(const Eigen::Vector2d& stream) const {
  std::optional<Ray> ray = model_->imageToRay(streamToCalibration(stream));
  if (!ray) return std::nullopt;
  ray->origin *= metres_per_unit_;
  ray->direction *= metres_per_unit_;
  return ray;
}

std::optional<Eigen::Vector3d> Camera::streamToPlane(const Eigen::Vector2d& stream,
                                                     double z_m) const {
  const std::optional<PlanePoint> point =
      model_->imageToPlane(streamToCalibration(stream), z_m / metres_per_unit_);
  if (!point) return std::nullopt;
  Eigen::Vector3d world = point->world * metres_per_unit_;
  world.z() = z_m;
  return world;
}

std::optional<int> Camera::pixelIndexAt(const Eigen::Vector2d& stream) const {
  // Pixel i covers [i - 0.5, i + 0.5): integer coordinates are pixel centres.
  const double u = std::floor(stream.x() + 0.5);
  const double v = std::floor(stream.y() + 0.5);
  if (!(u >= 0 && v >= 0 && u < stream_width_ && v < stream_height_)) return std::nullopt;
  return static_cast<int>(v) * stream_width_ + static_cast<int>(u);
}

Eigen::Vector3d Camera::centreMetres() const { return model_->centre() * metres_per_unit_; }

Camera Camera::turned(const Eigen::Vector3d& turn) const {
  return withModel(model_->withPose(turnedOnItsMount(model_->pose(), turn)));
}

Camera Camera::withModel(std::shared_ptr<const CameraModel> model) const {
  Camera out = *this;
  out.model_ = std::move(model);
  return out;
}

}  // namespace occmap
