#pragma once
// The floor hidden behind the people found (issue 14, docs/detection.md "Zones"): a map cell is
// occupied when every camera that sees it sees something changed on its column (the floor point
// and, with column carving, the column up to column_height_m above it), which is as true of the
// floor behind a person, or just in front of one, as of a person. Once people are found, the
// first can be told. A cell within half a box's width of someone found is theirs (never hidden);
// one just past that, within a box's width, is the edge of their blob on the map (the carving's
// column, cameras a frame apart, where they were found); and any other is hidden when, in every
// camera that sees it, its column's pixels meet the box of someone found. Nothing can be said of
// what stands there, so a zone whose occupied cells are all hidden is unseen, never free
// (core/zones.h, with footprints.hidden_floor_unseen).
// No I/O, no threads; nothing is allocated per map once the people found have their largest count.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "core/camera.h"
#include "core/footprints.h"
#include "core/map_geometry.h"

namespace occmap {

class HiddenFloor {
 public:
  // `cells`: the map cells that will be asked about (every zone's); `settings`: the people's box,
  // as the detector's (box_width_m, box_height_m); `column_height_m`: the fusion's (0: the floor).
  HiddenFloor(const MapGeometry& map, std::span<const std::uint32_t> cells,
              std::span<const Camera> cameras, const FootprintSettings& settings,
              double column_height_m);

  // The people found on the map asked about next (each with the height of the box it was found
  // with; 0: a person's).
  void setFound(std::span<const Detection> found);
  // Whether cells[i] is hidden behind the people found in every camera that sees it, or just
  // past someone found (false when no camera sees it, or someone found stands on it).
  bool hidden(std::size_t i) const;

  // A rectangle of pixels: the one holding a cell's column in a camera, or a person's box;
  // u0 > u1 where it is not in view.
  struct Rectangle {
    float u0, v0, u1, v1;
    bool seen() const { return u0 <= u1; }
  };

  // Each cell's column in `camera`'s image (a camera re-posed after a knock, core/repose.h):
  // projects every cell, so it is made off the map's path and handed to replaceCamera(). Reads
  // only what the constructor made: safe beside hidden() and setFound() on another thread.
  std::vector<Rectangle> sightsOf(const Camera& camera) const;
  // Camera k's new pose and its sightsOf(); nothing allocated.
  void replaceCamera(std::size_t k, Camera&& camera, std::span<const Rectangle> sights);

 private:
  Rectangle sightOf(const Camera& camera, std::size_t i) const;

  MapGeometry map_;
  std::vector<std::uint32_t> cells_;
  double column_height_m_;
  std::vector<Camera> camera_list_;
  std::vector<Eigen::Vector2d> below_;  // each camera's centre on the floor
  std::size_t cameras_;
  FootprintSettings box_;
  std::vector<Eigen::Vector2f> centres_;  // the cells'
  std::vector<Rectangle> sights_;         // cells x cameras
  std::vector<Rectangle> shadows_;        // found x cameras
  std::vector<Eigen::Vector2f> found_at_;
};

}  // namespace occmap
