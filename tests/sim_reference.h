#pragma once
// What a map of the simulated room must be: the reference fusion of exactly the frames the map says
// it used (each camera's `sequence`), re-rendered. The simulator is deterministic, so a map that
// went through the whole live pipeline and the network can be checked cell by cell.

#include <memory>
#include <vector>

#include "capture/sim/renderer.h"
#include "core/carve_table.h"
#include "core/reference_fusion.h"
#include "transport/map_codec.h"

namespace occmap::testing {

class SimRoomReference {
 public:
  // The room's four cameras at 30 fps, as sim://room/c0..c3 in this order, threshold 20.
  SimRoomReference(const MapGeometry& map, double column_height_m)
      : scene_(sim::makeScene("room")), map_(map) {
    for (std::size_t k = 0; k < scene_->cameras().size(); ++k) {
      renderers_.push_back(std::make_unique<sim::Renderer>(
          *scene_,
          Camera(std::make_shared<TsaiCamera>(scene_->cameras()[k].calibration),
                 LengthUnit::kMillimetre, 640, 480),
          static_cast<int>(k)));
      tables_.push_back(buildCarveTable(renderers_.back()->camera(), map, column_height_m,
                                        renderers_.back()->floorMask().view()));
    }
  }

  // The reference map for the frames `decoded` used; cameras it did not use are left out.
  OccupancyMap expected(const DecodedMap& decoded) const {
    std::vector<Image> live(renderers_.size());
    std::vector<CameraFrame> frames;
    for (std::size_t k = 0; k < renderers_.size(); ++k) {
      const bool used = k < decoded.cameras.size() && decoded.cameras[k].used;
      if (used) {
        const auto n = static_cast<std::uint64_t>(decoded.cameras[k].sequence);
        renderers_[k]->render(scene_->objectsAt(static_cast<double>(n) / 30.0), n, live[k]);
      }
      frames.push_back({&tables_[k], used ? live[k].view() : ImageView{},
                        renderers_[k]->background().view(), 20});
    }
    return fuseReference(map_, frames);
  }

  // The first cell where `decoded` differs from its reference, or -1.
  long firstDifference(const DecodedMap& decoded) const {
    const OccupancyMap reference = expected(decoded);
    if (decoded.cells.size() != reference.cells.size()) return 0;
    for (std::size_t cell = 0; cell < reference.cells.size(); ++cell) {
      if (decoded.cells[cell] != static_cast<std::uint8_t>(reference.cells[cell])) {
        return static_cast<long>(cell);
      }
    }
    return -1;
  }

 private:
  std::unique_ptr<sim::Scene> scene_;
  MapGeometry map_;
  std::vector<std::unique_ptr<sim::Renderer>> renderers_;
  std::vector<CarveTable> tables_;
};

}  // namespace occmap::testing
