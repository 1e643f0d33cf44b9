#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/image.h"
#include "core/map_geometry.h"

namespace occmap::tools {

// Pictures for people: the map drawn as a floor plan (+y up, +x right), with a scale bar.
// Colours (BGR): free near white, occupied near black, unseen a blue-grey so that it can never be
// taken for either.
cv::Mat floorPlan(const OccupancyMap& map, int pixels_per_cell);

// A 1 m (or fitting) scale bar at the bottom left of a floor-plan picture.
void drawScaleBar(cv::Mat& picture, const MapGeometry& map, int pixels_per_cell);

// Where a floor point lands in a floor-plan picture.
cv::Point floorPlanPoint(const MapGeometry& map, int pixels_per_cell, double x, double y);

// Camera images with their names, tiled two across, next to the floor plan of the map they made.
cv::Mat snapshot(const std::vector<std::pair<std::string, Image>>& cameras,
                 const OccupancyMap& map);

// A distinct colour for camera k (BGR), for legends.
cv::Scalar cameraColour(std::size_t k);

// Which cameras see each cell, as `occmap coverage` and `occmap web`'s /coverage.png colour it: one
// pixel per cell, +y up; `seen_by` holds, for each cell (row-major from map row 0), bit k set when
// camera k sees it. A cell is the mean of its cameras' colours (cameraColour), brighter the more
// see it; dark grey where none does.
cv::Mat coverageCells(const MapGeometry& map, std::span<const std::uint32_t> seen_by,
                      std::size_t cameras);

}  // namespace occmap::tools
