#pragma once
// Zones on the floor (issue 14, docs/detection.md): polygons a site names, such as a robot's
// cell, each with a state per map. A zone is OCCUPIED when any of its cells is occupied (the map
// cannot vouch for the floor behind people either, so for a safety zone that counts), UNSEEN when
// none is occupied but some cell is unseen, and FREE only when every cell is free. The time since
// it last changed is kept; time is passed in with each map.
// Given the cameras and the people found on the map, occupied cells that are only the floor
// hidden behind someone found (core/hidden_floor.h) make a zone UNSEEN rather than OCCUPIED: what
// stands there cannot be told, so it is never FREE either.
// No I/O, no threads; nothing is allocated per map.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/camera.h"
#include "core/footprints.h"
#include "core/hidden_floor.h"
#include "core/map_geometry.h"

namespace occmap {

struct ZoneSpec {
  std::string name;
  std::vector<Eigen::Vector2d> polygon_m;  // at least 3 corners, in order, in the map's frame
};

enum class ZoneState : std::uint8_t { kFree = 0, kOccupied = 1, kUnseen = 2 };
std::string_view zoneStateName(ZoneState state);

struct ZoneStatus {
  ZoneState state = ZoneState::kUnseen;
  double changed_s = 0.0;  // when it took this state (the first map's time at first)
  std::size_t cells = 0;   // whose centres lie inside the polygon
  std::size_t occupied_cells = 0;
  std::size_t unseen_cells = 0;
  // Every occupied cell is floor hidden behind someone found (the state is then UNSEEN).
  bool hidden_only = false;
};

// The map cells whose centres lie inside the polygon (even-odd rule).
std::vector<std::uint32_t> cellsInside(const MapGeometry& map,
                                       std::span<const Eigen::Vector2d> polygon_m);

class Zones {
 public:
  // Throws std::invalid_argument naming a zone with fewer than 3 corners or no cell of the map.
  Zones(const MapGeometry& map, std::span<const ZoneSpec> zones);
  // With the cameras and the people's box (the detector's), update() can tell the floor hidden
  // behind the people found from something standing in a zone.
  Zones(const MapGeometry& map, std::span<const ZoneSpec> zones, std::span<const Camera> cameras,
        const FootprintSettings& box, double column_height_m);

  // One map, at time_s (seconds, not decreasing), and the people found on it (or on a map just
  // before: none, the map's cells alone decide). Valid until the next call.
  const std::vector<ZoneStatus>& update(std::span<const CellState> cells, double time_s,
                                        std::span<const Detection> found = {});

  std::size_t size() const { return cells_.size(); }
  // Whether update() tells the floor hidden behind the people found (made with the cameras).
  bool tellsHiddenFloor() const { return hidden_.has_value(); }
  // A camera re-posed after a knock (core/repose.h): its zones' cells' columns in its new image,
  // made off the map's path (core/hidden_floor.h's sightsOf(), on any thread), then handed over
  // with the pose before the first map fused with it. Without the cameras, nothing to do.
  std::vector<HiddenFloor::Rectangle> sightsOf(const Camera& camera) const {
    return hidden_ ? hidden_->sightsOf(camera) : std::vector<HiddenFloor::Rectangle>{};
  }
  void replaceCamera(std::size_t k, Camera&& camera,
                     std::span<const HiddenFloor::Rectangle> sights) {
    if (hidden_) hidden_->replaceCamera(k, std::move(camera), sights);
  }
  std::span<const std::uint32_t> cells(std::size_t zone) const { return cells_[zone]; }

 private:
  std::size_t cell_count_;
  std::vector<std::vector<std::uint32_t>> cells_;
  // Each zone's cells as runs along the map's rows: counted 8 cells at a time.
  struct Run {
    std::uint32_t first_cell;  // in the map
    std::uint32_t count;
    std::uint32_t first;  // its first cell's place among every zone's cells, in order (hidden_'s)
  };
  std::vector<std::vector<Run>> runs_;
  std::vector<ZoneStatus> status_;
  std::optional<HiddenFloor> hidden_;  // with the cameras: every zone's cells, one after another
  bool started_ = false;
};

}  // namespace occmap
