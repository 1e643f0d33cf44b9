#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "capture/frame_source.h"
#include "capture/sim_source.h"
#include "core/camera.h"
#include "core/carve_table.h"
#include "core/image.h"
#include "daemon/config.h"

namespace occmap {

// One camera of a rig, opened: geometry as its stream sees it, background, mask and source.
struct RigCamera {
  std::string name;
  std::unique_ptr<Camera> camera;
  Image background;  // the stream's size
  Image floor_mask;  // the stream's size, or empty: every pixel is floor
  int threshold = 20;
  std::unique_ptr<FrameSource> source;
  SimSource* sim = nullptr;  // the same source when it is the simulator, for its ground truth
};

// Everything a config describes, opened and checked against each other: calibrations loaded, images
// read, sizes matched, sources opened. Anything wrong is an InputError naming the config line (or
// the calibration file and field) before any work starts.
class Rig {
 public:
  static Rig open(const Config& config);

  const Config& config() const { return config_; }
  std::vector<RigCamera>& cameras() { return cameras_; }
  const std::vector<RigCamera>& cameras() const { return cameras_; }
  // Advice a user should see that does not stop the work (e.g. a camera that sees no cell).
  const std::vector<std::string>& warnings() const { return warnings_; }
  // The simulated scene when every camera is a view of the same one (then ground truth is known).
  const sim::Scene* commonScene() const;

  // Each camera's carve table for the config's map, at the given column height, in camera order.
  // Cameras that see no cell of the map are reported in warnings().
  // `built` (if given) hears after each camera's table, for progress on large maps.
  std::vector<CarveTable> buildTables(double column_height_m,
                                      const std::function<void(std::size_t built)>& built = {});

 private:
  explicit Rig(Config config) : config_(std::move(config)) {}

  Config config_;
  std::vector<RigCamera> cameras_;
  std::vector<std::shared_ptr<const sim::Scene>> scenes_;
  std::vector<std::string> warnings_;
};

}  // namespace occmap
