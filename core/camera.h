#pragma once

#include <memory>
#include <optional>

#include "core/camera_model.h"

namespace occmap {

// The part of the calibration frame a stream covers: x0, y0, width, height in calibration pixels.
// A camera ROI is a crop, binning is a scale; both are this mapping per axis (ARCHITECTURE.md).
struct ImageRegion {
  double x0 = 0;
  double y0 = 0;
  double width = 0;
  double height = 0;
};

// A calibrated camera as its stream sees it and as the map needs it: world points in metres, pixels
// of the stream (which may cover another size or region than the calibration frame).
// u_s = (u - x0 + 0.5) W_s / w - 0.5, and likewise v: integer values are pixel centres in both.
class Camera {
 public:
  // `region` defaults to the whole calibration frame when its width or height is 0.
  Camera(std::shared_ptr<const CameraModel> model, LengthUnit units, int stream_width,
         int stream_height, ImageRegion region = {});

  const CameraModel& model() const { return *model_; }
  int streamWidth() const { return stream_width_; }
  int streamHeight() const { return stream_height_; }
  const ImageRegion& region() const { return region_; }
  double metresPerUnit() const { return metres_per_unit_; }

  Eigen::Vector2d calibrationToStream(const Eigen::Vector2d& calibration) const;
  Eigen::Vector2d streamToCalibration(const Eigen::Vector2d& stream) const;

  // A world point (metres) to its stream pixel coordinates; empty when the lens model has no image.
  std::optional<Eigen::Vector2d> worldToStream(const Eigen::Vector3d& world_m) const;
  // The ray of a stream pixel, in metres (origin = camera centre; direction's camera z = 1 unit).
  std::optional<Ray> streamToRay(const Eigen::Vector2d& stream) const;
  // Where a stream pixel's ray meets the plane at height z_m (metres), in front of the camera.
  std::optional<Eigen::Vector3d> streamToPlane(const Eigen::Vector2d& stream, double z_m) const;
  // The stream pixel containing stream coordinates, if it lies in the stream's bounds.
  std::optional<int> pixelIndexAt(const Eigen::Vector2d& stream) const;
  Eigen::Vector3d centreMetres() const;
  // The same camera turned on its mount by `turn` (axis times angle in radians, camera
  // coordinates): its coordinates become turn x the old ones, about the same centre.
  Camera turned(const Eigen::Vector3d& turn) const;
  // The same stream (size, region, units) seen through another model of the calibration frame.
  Camera withModel(std::shared_ptr<const CameraModel> model) const;

 private:
  std::shared_ptr<const CameraModel> model_;
  double metres_per_unit_;
  int stream_width_;
  int stream_height_;
  ImageRegion region_;
  double scale_x_;  // stream pixels per calibration pixel
  double scale_y_;
};

}  // namespace occmap
