#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "capture/frame_source.h"
#include "capture/sim_source.h"
#include "capture/source_spec.h"
#include "config/config.h"
#include "core/camera.h"
#include "core/carve_table.h"
#include "core/image.h"

namespace occmap {

struct RigOptions {
  // Read each camera's background image (false only to make one: `occmap background`).
  bool read_backgrounds = true;
  // Open only the camera of this name (the rig then holds just that one).
  std::optional<std::string> only_camera;
  // Open live cameras (aravis://, v4l2://) now. False leaves their sources empty for
  // openLiveCameras(): `occmapd --check` (a running daemon holds the cameras) and a reload (the
  // new config is checked and its tables built while the old one runs on).
  bool open_live_cameras = true;
  // Hears what a person should know that is not an error (a setting a camera adjusted, a camera
  // not there yet); default: standard error.
  std::function<void(const std::string& message)> notice;
};

// One camera of a rig, opened: geometry as its stream sees it, background, mask and source.
struct RigCamera {
  std::string name;
  std::unique_ptr<Camera> camera;
  Image background;  // the stream's size
  Image floor_mask;  // the stream's size, or empty: every pixel is floor
  int threshold = 20;
  LightingSettings lighting;            // the background that follows the light
  std::unique_ptr<FrameSource> source;  // empty for a live camera not opened yet
  bool live = false;                    // a camera (aravis://, v4l2://), not files or sim
  SimSource* sim = nullptr;  // the same source when it is the simulator, for its ground truth
};

// Everything a config describes, opened and checked against each other: calibrations loaded, images
// read, sizes matched, sources opened. Anything wrong is an InputError naming the config line (or
// the calibration file and field) before any work starts.
class Rig {
 public:
  static Rig open(const Config& config, const RigOptions& options = {});
  // A rig of cameras a program opened itself (a benchmark with pre-rendered frames): `config`
  // describes them in the same order (names, fps, thresholds, map, transport). Nothing is checked
  // beyond the count: the caller made the parts.
  static Rig assemble(Config config, std::vector<RigCamera> cameras);

  const Config& config() const { return config_; }
  std::vector<RigCamera>& cameras() { return cameras_; }
  const std::vector<RigCamera>& cameras() const { return cameras_; }
  // Advice a user should see that does not stop the work (e.g. a camera that sees no cell).
  const std::vector<std::string>& warnings() const { return warnings_; }
  // The simulated scene when every camera is a view of the same one (then ground truth is known).
  const sim::Scene* commonScene() const;

  // Opens the live cameras that open() left closed. With `previous` (the rig of the config before a
  // reload, its pipeline stopped), every camera whose source, settings, rate and size are
  // unchanged is taken over as it is, without reconnecting; the previous rig's other live cameras
  // are closed first. Throws InputError as open() does.
  void openLiveCameras(Rig* previous = nullptr);

  // Each camera's carve table for the config's map, at the given column height, in camera order.
  // Cameras that see no cell of the map are reported in warnings().
  // `built` (if given) hears after each camera's table, for progress on large maps.
  std::vector<CarveTable> buildTables(double column_height_m,
                                      const std::function<void(std::size_t built)>& built = {});

 private:
  explicit Rig(Config config) : config_(std::move(config)) {}
  void openLiveCamera(std::size_t index, const SourceSpec& spec);

  Config config_;
  std::vector<RigCamera> cameras_;
  std::vector<std::shared_ptr<const sim::Scene>> scenes_;
  std::vector<std::string> warnings_;
  std::function<void(const std::string& message)> notice_;
};

}  // namespace occmap
