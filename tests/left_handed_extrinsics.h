#pragma once
// A camera's extrinsics as a left-handed world (Unity's, MultiviewX's) would have them, for tests
// of world_frame: left-handed.

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

namespace occmap::testing {

struct Extrinsics {
  cv::Vec3d rvec;
  cv::Vec3d tvec;
};

// The camera of (rvec, tvec) written in a left-handed world (the floor's z mirrored, M = diag(1, 1,
// -1)) with its frame mirrored too: R' = -R M (a proper rotation, as det(-M) = 1) and t' = -t, so
// that R' Xw + t' = -(R Xw + t) for every floor point: each at negative depth, where
// cv::projectPoints still gives it the right-handed camera's pixel.
inline Extrinsics leftHandedExtrinsics(const cv::Vec3d& rvec, const cv::Vec3d& tvec) {
  cv::Mat r;
  cv::Rodrigues(rvec, r);
  const cv::Mat mirror = (cv::Mat_<double>(3, 3) << 1, 0, 0, 0, 1, 0, 0, 0, -1);
  Extrinsics left;
  cv::Rodrigues(cv::Mat(r * (-mirror)), left.rvec);
  left.tvec = -tvec;
  return left;
}

}  // namespace occmap::testing
