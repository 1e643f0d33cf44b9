#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "capture/sim/renderer.h"
#include "core/camera.h"
#include "core/image.h"

namespace occmap::sim {

// A printed planar target (a ChArUco board, a chessboard) held in front of a camera, for
// calibrating its lens with occmap itself (issue 15).
//
// The target's picture `texture` (8-bit grey) covers width_m x height_m of paper, texture row 0 at
// the top edge and column 0 at the left edge. Held at `board_to_camera`, the point at paper
// coordinates (x right, y down, z = 0; origin the texture's top-left corner) lies at R (x, y, 0) +
// t in the camera's coordinates (x right, y down, z forward): OpenCV's convention for a board's
// rvec / tvec (R = Rodrigues(rvec)), in metres.
struct TargetPose {
  Eigen::Vector3d rvec;
  Eigen::Vector3d tvec;
};

// Where the paper point (x, y) of a target held at `pose` lies in the world (metres).
Eigen::Vector3d targetPointInWorld(const Camera& camera, const TargetPose& pose,
                                   const Eigen::Vector2d& paper_m);

// The camera's view of its empty scene with the target in front of it (the room behind does not
// hide it): 4 x 4 rays a pixel where the target is seen, the texture sampled bilinearly, and the
// sensor noise every simulated camera has, the same for the same seed. Any lens model: the rays
// come from Camera::streamToRay.
Image renderTargetView(const Renderer& empty_view, const cv::Mat& texture, double width_m,
                       double height_m, const TargetPose& pose, std::uint64_t noise_seed);

// `count` poses a person calibrating a camera would hold the target at, the same every time: the
// target filling some 15 to 45 % of the image, tilted up to about 35 degrees about its axes, at the
// image's centre, edges and corners (where the lens distorts most), wholly inside the image with a
// margin, its printed side facing the camera.
// With `partly_in_view` (a ChArUco board, whose corners are told apart by their markers) up to
// 30 % of the target's outline may lie outside the picture, as a person reaches into its corners.
std::vector<TargetPose> targetPosesFor(const Camera& camera, double width_m, double height_m,
                                       int count, bool partly_in_view = false);

}  // namespace occmap::sim
