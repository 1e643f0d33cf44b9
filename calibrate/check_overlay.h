#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "core/camera.h"
#include "core/floor_marker.h"
#include "core/image.h"
#include "core/map_geometry.h"

namespace occmap {

// What a person checks a calibration by (`occmap calibrate check`, docs/calibration.md): drawn into
// the camera's own picture through its calibration, the map's outline (yellow), a 1 m grid on the
// floor (cyan; the lines x = 0 and y = 0 thicker), the markers with their ids (magenta) and the
// edge of the floor mask (green). Lines follow the lens's distortion. Where the calibration is
// right they lie on the floor's features and the markers' outlines on the printed markers.
struct CheckOverlay {
  cv::Mat picture;        // BGR
  int markers_drawn = 0;  // markers with a corner in the image
  int grid_lines = 0;     // grid lines with a piece in the image
};

CheckOverlay drawCheckOverlay(const cv::Mat& grey, const Camera& camera, const MapGeometry& map,
                              const std::vector<FloorMarker>& markers, const Image* floor_mask);

}  // namespace occmap
