#pragma once

#include <array>
#include <vector>

#include <opencv2/core.hpp>

namespace occmap {

// One marker found in an image: its id and its four corners in OpenCV's order (top-left,
// top-right, bottom-right, bottom-left as printed), sub-pixel, the top-left pixel's centre at (0,
// 0).
struct MarkerSighting {
  int id = 0;
  std::array<cv::Point2f, 4> corners;
  bool refined = true;  // false: an edge could not be measured, the corners are OpenCV's outline's
};

// The markers of the dictionary (cv::aruco::PREDEFINED_DICTIONARY_NAME) in an 8-bit grey image,
// each corner where the marker's two outer edges meet: each edge located where the grey crosses
// halfway from ink to paper, along its normal, at points all along it, and a line fitted to them.
// OpenCV 4.6's own sub-pixel refinement (cornerSubPix on the corner) pulls the corners of small
// markers seen at a slant 0.5 to 2 pixels inward, as its window takes in the marker's inner cells;
// the edges give them to about 0.05 px (tests/sim_calibration_targets_test.cpp).
std::vector<MarkerSighting> findMarkers(const cv::Mat& grey, int dictionary);

}  // namespace occmap
